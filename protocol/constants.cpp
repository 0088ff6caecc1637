#include "protocol/constants.h"

namespace myriad::protocol {

std::string expandRoute(std::string_view route, std::string_view name, std::string_view value) {
  std::string placeholder(1, '{');  // not "{" + ...: GCC 12 warns falsely (-Wrestrict)
  placeholder.append(name);
  placeholder += '}';
  std::string out(route);
  for (size_t at = out.find(placeholder); at != std::string::npos;
       at = out.find(placeholder, at + value.size())) {
    out.replace(at, placeholder.size(), value);
  }
  return out;
}

std::string problemTypeUri(std::string_view name) {
  return std::string(problems::kTypePrefix) + std::string(name);
}

std::string_view problemTypeName(std::string_view typeUri) {
  if (typeUri.substr(0, problems::kTypePrefix.size()) != problems::kTypePrefix) return {};
  std::string_view name = typeUri.substr(problems::kTypePrefix.size());
  for (std::string_view known : problems::kAll) {
    if (known == name) return known;
  }
  return {};
}

}  // namespace myriad::protocol
