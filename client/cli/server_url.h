// The --server URL: scheme, host, port and an optional path prefix (for a server behind a
// reverse proxy at http://host/myriad). Pure parsing, no I/O.
#pragma once

#include <string>

namespace myriad::cli {

struct ServerUrl {
  std::string scheme;    // "http" or "https"
  std::string host;      // "127.0.0.1", "example.org", "::1" (without brackets)
  int port = 0;          // 80/443 when the URL names none
  std::string basePath;  // "" or "/myriad": put before every /v1/... path

  // "http://127.0.0.1:8080", with brackets around an IPv6 host: what httplib::Client takes.
  std::string origin() const;
  // As the user would write it, for messages.
  std::string text() const { return origin() + basePath; }
};

inline constexpr const char* kDefaultServer = "http://127.0.0.1:8080";

// Throws UsageError naming `argument` ("--server" or "MYRIAD_SERVER") when `text` is not an
// http(s) URL with a host, an optional port 1..65535 and an optional path.
ServerUrl parseServerUrl(const std::string& text, const std::string& argument);

// Percent-encodes `text` for a query value or a path segment (RFC 3986 unreserved kept).
std::string percentEncode(const std::string& text);

}  // namespace myriad::cli
