#include "protocol/schema_bundle.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

namespace myriad::protocol {
namespace {

struct ParsedBundle {
  std::map<std::string, nlohmann::json, std::less<>> schemas;
};

// Parsed once, on first use; read-only afterwards, so safe to share between threads.
const ParsedBundle& bundle() {
  static const ParsedBundle parsed = [] {
    ParsedBundle b;
    for (const detail::EmbeddedSchema& s : detail::embeddedSchemas()) {
      b.schemas.emplace(std::string(s.name), nlohmann::json::parse(s.text));
    }
    return b;
  }();
  return parsed;
}

const detail::EmbeddedSchema& embedded(std::string_view name) {
  for (const detail::EmbeddedSchema& s : detail::embeddedSchemas()) {
    if (s.name == name) return s;
  }
  throw std::invalid_argument("protocol: no schema named \"" + std::string(name) + "\"");
}

}  // namespace

const std::vector<std::string_view>& schemaNames() {
  static const std::vector<std::string_view> names = [] {
    std::vector<std::string_view> sorted;
    for (const detail::EmbeddedSchema& s : detail::embeddedSchemas()) sorted.push_back(s.name);
    std::sort(sorted.begin(), sorted.end());
    return sorted;
  }();
  return names;
}

const nlohmann::json& schema(std::string_view name) {
  const auto& schemas = bundle().schemas;
  auto it = schemas.find(name);
  if (it == schemas.end()) {
    throw std::invalid_argument("protocol: no schema named \"" + std::string(name) + "\"");
  }
  return it->second;
}

std::string_view schemaText(std::string_view name) { return embedded(name).text; }

}  // namespace myriad::protocol
