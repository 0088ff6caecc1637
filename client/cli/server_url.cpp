#include "server_url.h"

#include "args.h"

namespace myriad::cli {

std::string ServerUrl::origin() const {
  std::string shownHost = host.find(':') != std::string::npos ? "[" + host + "]" : host;
  return scheme + "://" + shownHost + ":" + std::to_string(port);
}

ServerUrl parseServerUrl(const std::string& text, const std::string& argument) {
  auto fail = [&](const std::string& why) -> ServerUrl {
    throw UsageError(argument, argument + ": \"" + text + "\" is not a server URL: " + why +
                                   " (example: http://127.0.0.1:8080)");
  };
  ServerUrl url;
  size_t schemeEnd = text.find("://");
  if (schemeEnd == std::string::npos) return fail("it has no http:// in front");
  url.scheme = text.substr(0, schemeEnd);
  if (url.scheme != "http" && url.scheme != "https") return fail("only http and https are served");
  std::string rest = text.substr(schemeEnd + 3);
  size_t pathStart = rest.find('/');
  std::string authority = rest.substr(0, pathStart);
  if (pathStart != std::string::npos) url.basePath = rest.substr(pathStart);
  while (!url.basePath.empty() && url.basePath.back() == '/') url.basePath.pop_back();
  if (url.basePath.find_first_of("?#") != std::string::npos) {
    return fail("it has a query or fragment");
  }
  if (authority.find('@') != std::string::npos) return fail("user names in URLs are not supported");

  std::string portText;
  if (!authority.empty() && authority.front() == '[') {  // [::1]:8080
    size_t close = authority.find(']');
    if (close == std::string::npos) return fail("the IPv6 address has no closing ]");
    url.host = authority.substr(1, close - 1);
    std::string after = authority.substr(close + 1);
    if (!after.empty()) {
      if (after.front() != ':') return fail("unexpected text after the IPv6 address");
      portText = after.substr(1);
      if (portText.empty()) return fail("the port is empty");
    }
  } else {
    size_t colon = authority.rfind(':');
    url.host = authority.substr(0, colon);
    if (colon != std::string::npos) {
      portText = authority.substr(colon + 1);
      if (portText.empty()) return fail("the port is empty");
    }
  }
  if (url.host.empty()) return fail("it has no host");
  if (portText.empty()) {
    url.port = url.scheme == "https" ? 443 : 80;
  } else {
    if (portText.find_first_not_of("0123456789") != std::string::npos || portText.size() > 5) {
      return fail("the port is not a number");
    }
    url.port = std::stoi(portText);
    if (url.port < 1 || url.port > 65535) return fail("the port is not from 1 to 65535");
  }
  return url;
}

std::string percentEncode(const std::string& text) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    bool unreserved = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                      c == '-' || c == '.' || c == '_' || c == '~';
    if (unreserved) {
      out += char(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

}  // namespace myriad::cli
