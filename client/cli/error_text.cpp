#include "error_text.h"

#include <nlohmann/json.hpp>

#include "protocol/constants.h"

namespace myriad::cli {
namespace {

std::string reasonPhrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 409: return "Conflict";
    case 413: return "Content Too Large";
    case 415: return "Unsupported Media Type";
    case 422: return "Unprocessable Content";
    case 429: return "Too Many Requests";
    case 500: return "Internal Server Error";
    case 502: return "Bad Gateway";
    case 503: return "Service Unavailable";
    case 504: return "Gateway Timeout";
    default: return "";
  }
}

std::string typeName(const std::string& type) {
  size_t slash = type.rfind('/');
  std::string name = slash == std::string::npos ? type : type.substr(slash + 1);
  return name.empty() ? type : name;
}

}  // namespace

std::string oneLine(const std::string& text, size_t maxLength) {
  std::string out;
  for (unsigned char c : text) {
    char shown = (c < 0x20 || c == 0x7f) ? ' ' : char(c);
    if (shown == ' ' && (out.empty() || out.back() == ' ')) continue;
    out += shown;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  if (out.size() > maxLength) {
    size_t cut = maxLength;
    // Do not cut a UTF-8 sequence in half.
    while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xC0) == 0x80) --cut;
    out = out.substr(0, cut) + "...";
  }
  return out;
}

std::string describeErrorResponse(int status, const std::string& contentType,
                                  const std::string& body) {
  const std::string statusText = std::to_string(status);
  if (contentType.starts_with(protocol::kProblemContentType) ||
      contentType.starts_with(protocol::kJsonContentType)) {
    nlohmann::json problem = nlohmann::json::parse(body, nullptr, false);
    if (problem.is_object()) {
      std::string detail, type;
      if (auto it = problem.find("detail"); it != problem.end() && it->is_string()) detail = *it;
      if (auto it = problem.find("title"); detail.empty() && it != problem.end() && it->is_string())
        detail = *it;
      if (auto it = problem.find("type"); it != problem.end() && it->is_string()) type = *it;
      if (!detail.empty() || !type.empty()) {
        std::string name = type.empty() ? reasonPhrase(status) : typeName(type);
        if (detail.empty()) detail = "the server refused the request";
        return oneLine(detail) + " (" + statusText + (name.empty() ? "" : " " + name) + ")";
      }
    }
  }
  std::string reason = reasonPhrase(status);
  std::string firstLine = oneLine(body.substr(0, body.find('\n')), 200);
  std::string detail = firstLine.empty() ? "the server answered with an error" : firstLine;
  return detail + " (" + statusText + (reason.empty() ? "" : " " + reason) + ")";
}

}  // namespace myriad::cli
