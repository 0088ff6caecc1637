// The little HTTP layer `myriad` needs on top of cpp-httplib: one server, an optional bearer
// token, JSON in and out, and every failure turned into one sentence (ApiError). http and https
// URLs are both accepted (Debian's cpp-httplib is built with OpenSSL); the server speaks http, so
// only http is tested.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "server_url.h"

namespace httplib {
class Client;
struct Request;
}

namespace myriad::cli {

// A failure to show the user as "myriad: <what()>" with exit status 1: a problem response
// ("<detail> (<status> <type>)"), an unreachable server, a broken response.
class ApiError : public std::runtime_error {
 public:
  explicit ApiError(const std::string& message, int status = 0)
      : std::runtime_error(message), status_(status) {}
  int status() const { return status_; }  // 0 when no response came

 private:
  int status_;
};

using Query = std::vector<std::pair<std::string, std::string>>;

struct HttpResponse {
  int status = 0;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;

  // The first header of that name (case-insensitive), or "".
  std::string header(const std::string& name) const;
};

class HttpClient {
 public:
  explicit HttpClient(ServerUrl url);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  const ServerUrl& url() const { return url_; }
  void setBearer(std::string token) { bearer_ = std::move(token); }
  // Sent as If-Match with every request but GET while set (protocol/reference.md "Conditional
  // edits"); std::nullopt: edits apply to the session's latest version.
  void setIfMatch(std::optional<std::string> tag) { ifMatch_ = std::move(tag); }
  const std::optional<std::string>& ifMatch() const { return ifMatch_; }
  // The ETag of the last answer that had one ("" before any): the session's version it saw.
  const std::string& lastETag() const { return lastETag_; }

  // Sends the request and returns the response whatever its status; throws ApiError when no
  // response came (connection refused, timeout).
  HttpResponse send(const std::string& method, const std::string& path, const Query& query = {},
                    const std::string& body = {}, const std::string& contentType = {});

  // As send(), but a status of 400 or more throws ApiError with the problem's one line.
  HttpResponse sendOk(const std::string& method, const std::string& path, const Query& query = {},
                      const std::string& body = {}, const std::string& contentType = {});

  // A JSON request (body may be null: none sent) whose answer is JSON; a 204 or empty answer
  // gives null. `raw`, when given, receives the body as it came (for --json).
  nlohmann::json sendJson(const std::string& method, const std::string& path,
                          const nlohmann::json& body = nullptr, const Query& query = {},
                          std::string* raw = nullptr);

  // GET with the body handed to `onData` as it arrives, after `onHead` has seen a 2xx status and
  // the headers; either returns false to stop. An error status throws ApiError with the problem.
  // Stopping on purpose is not an error.
  void stream(const std::string& path, const Query& query,
              const std::function<bool(const HttpResponse& head)>& onHead,
              const std::function<bool(const char* data, size_t size)>& onData);

 private:
  std::string target(const std::string& path, const Query& query) const;
  // Authorization: Bearer <token>, when a session token is set.
  void addBearer(httplib::Request& req) const;
  [[noreturn]] void failTransport(int error) const;

  ServerUrl url_;
  std::optional<std::string> bearer_;
  std::optional<std::string> ifMatch_;
  std::string lastETag_;
  std::unique_ptr<httplib::Client> client_;
};

}  // namespace myriad::cli
