// A small JSON client of the session API for the api tests (api_tests.cpp, api_frames_tests.cpp):
// requests with a session's bearer token, answers parsed, problems checked in one call.
#pragma once

#include <httplib.h>

#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "server_process.h"

namespace myriad::test {

struct Reply {
  int status = 0;  // 0 when the request failed (no connection, timeout)
  std::string body;
  httplib::Headers headers;
  nlohmann::json json;  // the body parsed when it is JSON, else null

  std::string header(const std::string& name) const;
};

class ApiClient {
 public:
  explicit ApiClient(const ServerProcess& server);

  // `token`: sent as Authorization: Bearer <token> when not empty.
  Reply get(const std::string& path, const std::string& token = "");
  Reply del(const std::string& path, const std::string& token = "");
  // JSON bodies; `body` as text so tests can send what is not valid JSON.
  Reply post(const std::string& path, const std::string& body, const std::string& token = "",
             const std::string& contentType = "application/json");
  Reply put(const std::string& path, const std::string& body, const std::string& token = "",
            const std::string& contentType = "application/json");
  Reply patch(const std::string& path, const std::string& body, const std::string& token = "",
              const std::string& contentType = "application/json");
  // Any method with any headers.
  Reply send(const std::string& method, const std::string& path, const std::string& body,
             const httplib::Headers& headers, const std::string& contentType = "");

  httplib::Client& raw() { return *client_; }

 private:
  std::unique_ptr<httplib::Client> client_;
};

struct TestSession {
  std::string id;
  std::string token;
  nlohmann::json created;  // the 201 body
  std::string path() const { return "/v1/sessions/" + id; }
};

// POST /v1/sessions with `body`; REQUIREs 201.
TestSession createSession(ApiClient& api, const std::string& body = "{}",
                          const std::string& apiKey = "");

// CHECKs a problem response: status, content type, type name (the last segment of the type URI),
// and, when given, `pointer`, `parameter` and `limit`.
void checkProblem(const Reply& reply, int status, const std::string& typeName,
                  const std::string& context, std::optional<std::string> pointer = std::nullopt,
                  std::optional<std::string> limit = std::nullopt,
                  std::optional<std::string> parameter = std::nullopt);

// GET /v1/info's validation message count (REQUIREs the request to work).
uint64_t validationMessages(ApiClient& api);

}  // namespace myriad::test
