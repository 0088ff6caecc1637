// The access log over loopback against the real server (issue 33, "Operating it"): one JSON line
// per request on stderr with its id, route template, session, status, latency and node; the
// request id taken from the client or made, and returned; no token anywhere in the log.
#include <doctest/doctest.h>

#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "server_process.h"

using nlohmann::json;
using myriad::test::ApiClient;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using myriad::test::createSession;
using myriad::test::mintViewer;

namespace {

// The stderr lines that are JSON objects with a requestId: the access log's.
std::vector<json> accessLines(const std::string& text) {
  std::vector<json> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line.front() != '{') continue;
    json entry = json::parse(line, nullptr, false);
    if (entry.is_object() && entry.contains("requestId")) lines.push_back(std::move(entry));
  }
  return lines;
}

}  // namespace

TEST_CASE("access log: a JSON line per request with its id, route, status and node; no token") {
  ServerProcess server({"--lights", "8", "--node-id", "7"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string viewer = mintViewer(api, s);

  // The client's own id comes back; a hostile one is replaced by one made for it.
  Reply mine = api.send("GET", s.path() + "/camera", "",
                        {{"Authorization", "Bearer " + s.token}, {"X-Request-Id", "trace:42.a_b-c"}});
  REQUIRE(mine.status == 200);
  CHECK(mine.header("X-Request-Id") == "trace:42.a_b-c");
  Reply hostile = api.send("GET", "/v1/health", "", {{"X-Request-Id", "a b\"{}"}});
  const std::string made = hostile.header("X-Request-Id");
  CHECK(std::regex_match(made, std::regex("[0-9a-f]{8}-[0-9a-f]{12}")));
  CHECK(api.get("/v1/health").header("X-Request-Id") != made);

  // Tokens in every place a client puts them: the header, ?token= on a frame, a bad one.
  CHECK(api.patch(s.path() + "/camera", R"({"fovY": 50})", s.token).status == 200);
  CHECK(api.get(s.path() + "/frame?width=32&height=24&token=" + viewer).status == 200);
  CHECK(api.get(s.path() + "/frame?width=32&height=24&token=" + std::string(64, 'f')).status == 401);
  CHECK(api.get("/v1/nothing-here").status == 404);

  server.stop();
  const std::string log = server.stderrText();
  CHECK(log.find(s.token) == std::string::npos);
  CHECK(log.find(viewer) == std::string::npos);
  CHECK(log.find(std::string(64, 'f')) == std::string::npos);

  const std::vector<json> lines = accessLines(log);
  REQUIRE(lines.size() >= 8);
  std::set<std::string> ids;
  for (const json& entry : lines) {
    for (const char* key : {"time", "requestId", "method", "route", "status", "bytes", "latencyMs"}) {
      CHECK_MESSAGE(entry.contains(key), key, " in ", entry.dump());
    }
    CHECK(entry.value("node", "") == "7");
    CHECK(entry.at("latencyMs").get<double>() >= 0.0);
    CHECK(std::regex_match(entry.value("time", ""),
                           std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z)")));
    ids.insert(entry.value("requestId", ""));
  }
  CHECK(ids.size() == lines.size());  // every request its own id
  auto find = [&](const std::string& id) {
    for (const json& entry : lines) {
      if (entry["requestId"] == id) return entry;
    }
    return json();
  };
  const json traced = find("trace:42.a_b-c");
  REQUIRE(traced.is_object());
  CHECK(traced["method"] == "GET");
  CHECK(traced["route"] == "/v1/sessions/{id}/camera");
  CHECK(traced["session"] == s.id);
  CHECK(traced["status"] == 200);
  CHECK(find(made)["route"] == "/v1/health");
  bool refusedFrame = false, unmatched = false;
  for (const json& entry : lines) {
    refusedFrame |= entry["route"] == "/v1/sessions/{id}/frame" && entry["status"] == 401;
    unmatched |= entry["route"] == "unmatched" && entry["status"] == 404;
  }
  CHECK(refusedFrame);
  CHECK(unmatched);
}
