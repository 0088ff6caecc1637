// The HTTP layer against a small in-process cpp-httplib server (no renderer): JSON answers, problem
// responses as one line, the bearer token, query encoding, a path prefix, a multipart stream
// stopped early, exceptions from stream callbacks, and a refused connection.
#include <doctest/doctest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <stdexcept>
#include <thread>

#include "http.h"
#include "multipart.h"

using namespace myriad::cli;

namespace {

// An httplib server on a free loopback port, serving on its own thread while in scope.
class FakeServer {
 public:
  explicit FakeServer(const std::function<void(httplib::Server&)>& routes) {
    routes(server_);
    port_ = server_.bind_to_any_port("127.0.0.1");
    REQUIRE(port_ > 0);
    thread_ = std::thread([this] { server_.listen_after_bind(); });
  }
  ~FakeServer() {
    server_.stop();
    thread_.join();
  }
  ServerUrl url(const std::string& prefix = "") const {
    return parseServerUrl("http://127.0.0.1:" + std::to_string(port_) + prefix, "--server");
  }

 private:
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
};

const char* kProblem =
    R"({"type":"https://myriad.dev/problems/not-found","title":"Not found","status":404,)"
    R"("detail":"The session has no light \"7\"."})";

}  // namespace

TEST_CASE("JSON answers, bearer token, query encoding, path prefix") {
  FakeServer server([](httplib::Server& s) {
    s.Get("/base/v1/echo", [](const httplib::Request& req, httplib::Response& res) {
      nlohmann::json body = {{"auth", req.get_header_value("Authorization")},
                             {"name", req.get_param_value("name")}};
      res.set_content(body.dump(), "application/json");
    });
    s.Patch("/base/v1/thing", [](const httplib::Request& req, httplib::Response& res) {
      auto in = nlohmann::json::parse(req.body);
      in["seen"] = req.get_header_value("Content-Type");
      res.set_content(in.dump(), "application/json");
    });
    s.Delete("/base/v1/thing", [](const httplib::Request&, httplib::Response& res) {
      res.status = 204;
    });
  });
  HttpClient http(server.url("/base"));
  http.setBearer("tok123");
  std::string raw;
  nlohmann::json echo = http.sendJson("GET", "/v1/echo", nullptr, {{"name", "a b&c=d/é"}}, &raw);
  CHECK(echo["auth"] == "Bearer tok123");
  CHECK(echo["name"] == "a b&c=d/é");
  CHECK(nlohmann::json::parse(raw) == echo);

  nlohmann::json patched = http.sendJson("PATCH", "/v1/thing", {{"fovY", 40}});
  CHECK(patched["fovY"] == 40);
  CHECK(patched["seen"] == "application/json");
  CHECK(http.sendJson("DELETE", "/v1/thing").is_null());
}

TEST_CASE("error statuses become one line; a non-JSON answer is an error") {
  FakeServer server([](httplib::Server& s) {
    s.Get("/v1/problem", [](const httplib::Request&, httplib::Response& res) {
      res.status = 404;
      res.set_content(kProblem, "application/problem+json");
    });
    s.Get("/v1/html", [](const httplib::Request&, httplib::Response& res) {
      res.set_content("<html>hello</html>", "text/html");
    });
  });
  HttpClient http(server.url());
  try {
    http.sendJson("GET", "/v1/problem");
    FAIL("no error");
  } catch (const ApiError& e) {
    CHECK(std::string(e.what()) == "The session has no light \"7\". (404 not-found)");
    CHECK(e.status() == 404);
  }
  CHECK_THROWS_WITH_AS(http.sendJson("GET", "/v1/html"),
                       "the server's answer to GET /v1/html is not JSON (200)", ApiError);
  // send() itself hands back any status.
  CHECK(http.send("GET", "/v1/problem").status == 404);
}

TEST_CASE("a multipart stream read part by part and stopped early") {
  FakeServer server([](httplib::Server& s) {
    s.Get("/v1/stream", [](const httplib::Request&, httplib::Response& res) {
      res.set_chunked_content_provider(
          "multipart/x-mixed-replace; boundary=myriad-frame",
          [n = 0](size_t, httplib::DataSink& sink) mutable {
            if (n == 50) {
              sink.done();
              return true;
            }
            std::string body = "image-" + std::to_string(n);
            std::string part = "--myriad-frame\r\nContent-Type: image/jpeg\r\nContent-Length: " +
                               std::to_string(body.size()) + "\r\nX-Myriad-Frame: " +
                               std::to_string(n) + "\r\n\r\n" + body + "\r\n";
            ++n;
            return sink.write(part.data(), part.size());
          });
    });
    s.Get("/v1/busy", [](const httplib::Request&, httplib::Response& res) {
      res.status = 429;
      res.set_content(R"({"type":"https://myriad.dev/problems/limit-exceeded","title":"t",)"
                      R"("status":429,"detail":"Too many streams.","limit":"maxStreams"})",
                      "application/problem+json");
    });
  });
  HttpClient http(server.url());

  std::optional<MultipartReader> reader;
  std::vector<std::string> bodies;
  http.stream(
      "/v1/stream", {},
      [&](const HttpResponse& head) {
        reader.emplace(*multipartBoundary(head.header("content-type")));
        return true;
      },
      [&](const char* data, size_t size) {
        for (auto& part : reader->feed(std::string_view(data, size))) bodies.push_back(part.body);
        return bodies.size() < 3;
      });
  REQUIRE(bodies.size() >= 3);
  CHECK(bodies[0] == "image-0");
  CHECK(bodies[2] == "image-2");

  CHECK_THROWS_WITH_AS(
      http.stream("/v1/busy", {}, [](const HttpResponse&) { return true; },
                  [](const char*, size_t) { return true; }),
      "Too many streams. (429 limit-exceeded)", ApiError);

  // An exception in a callback reaches the caller as itself, not as a transport error.
  CHECK_THROWS_WITH_AS(
      http.stream("/v1/stream", {}, [](const HttpResponse&) { return true; },
                  [](const char*, size_t) -> bool { throw std::runtime_error("disk full"); }),
      "disk full", std::runtime_error);
}

TEST_CASE("nothing listening: one sentence naming the URL") {
  // A port bound and closed again, never listened on.
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
  socklen_t length = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length);
  close(fd);
  const int port = ntohs(addr.sin_port);
  HttpClient http(parseServerUrl("http://127.0.0.1:" + std::to_string(port), "--server"));
  try {
    http.send("GET", "/v1/health");
    FAIL("connected");
  } catch (const ApiError& e) {
    CHECK(std::string(e.what()) == "cannot connect to a Myriad server at http://127.0.0.1:" +
                                       std::to_string(port) +
                                       ": is myriad-server running there? (set --server or "
                                       "MYRIAD_SERVER)");
    CHECK(e.status() == 0);
  }
}
