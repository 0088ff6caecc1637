// Optimistic concurrency over loopback against the real server (issue 33): every session answer
// carries the session's version as an ETag; an edit with If-Match applies only to that version
// (412 precondition-failed otherwise, naming the current ETag); without If-Match an edit applies
// to the latest version. Every edit route of the protocol's operation table is tried.
#include <doctest/doctest.h>

#include <atomic>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "protocol/constants.h"
#include "protocol/operations.h"
#include "server_process.h"

using nlohmann::json;
using myriad::test::ApiClient;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using myriad::test::checkProblem;
using myriad::test::createSession;
namespace protocol = myriad::protocol;

namespace {

const std::string kETag(protocol::headers::kETag);
const std::string kIfMatch(protocol::headers::kIfMatch);

httplib::Headers conditional(const TestSession& s, const std::string& tag) {
  return {{"Authorization", "Bearer " + s.token}, {kIfMatch, tag}};
}

// A route template with every {name} but the session's filled with `1`.
std::string concretePath(std::string_view route, const TestSession& s) {
  std::string path = std::regex_replace(std::string(route), std::regex(R"(\{id\})"), s.id);
  return std::regex_replace(path, std::regex(R"(\{[a-z]+\})"), "1");
}

}  // namespace

TEST_CASE("conditional edits: ETag on every answer; a stale If-Match is a 412 on every edit route") {
  ServerProcess server({"--lights", "8"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession s = createSession(api);

  const Reply camera = api.get(s.path() + "/camera", s.token);
  REQUIRE(camera.status == 200);
  const std::string tag = camera.header(kETag);
  REQUIRE(std::regex_match(tag, std::regex(R"("[0-9]+-[0-9a-f]{8}")")));
  // Reads do not move it; every session resource answers the same tag.
  for (const char* part : {"", "/camera", "/settings", "/lights", "/materials", "/objects"}) {
    const Reply read = api.get(s.path() + part, s.token);
    CHECK_MESSAGE(read.header(kETag) == tag, "GET ", part);
  }

  // An edit naming the current tag applies and answers the next one.
  const Reply edited = api.send("PATCH", s.path() + "/camera", R"({"fovY": 50})",
                                conditional(s, tag), "application/json");
  REQUIRE(edited.status == 200);
  const std::string next = edited.header(kETag);
  CHECK(next != tag);
  CHECK(api.get(s.path() + "/camera", s.token).header(kETag) == next);

  // The same edit again with the old tag: 412, the current tag in the header and the detail,
  // and nothing changed.
  const Reply stale = api.send("PATCH", s.path() + "/camera", R"({"fovY": 70})",
                               conditional(s, tag), "application/json");
  checkProblem(stale, 412, "precondition-failed", "PATCH with a stale If-Match");
  CHECK(stale.header(kETag) == next);
  CHECK(stale.json.value("detail", "").find(next) != std::string::npos);
  const Reply after = api.get(s.path() + "/camera", s.token);
  CHECK(after.json.at("fovY") == 50);
  CHECK(after.header(kETag) == next);

  // `*` and a list naming the current tag match; a weak tag never does (strong comparison).
  CHECK(api.send("PATCH", s.path() + "/camera", R"({"fovY": 51})", conditional(s, "*"),
                 "application/json").status == 200);
  const std::string now = api.get(s.path() + "/camera", s.token).header(kETag);
  CHECK(api.send("PATCH", s.path() + "/camera", R"({"fovY": 52})",
                 conditional(s, "\"0-00000000\", " + now), "application/json").status == 200);
  const std::string weak = "W/" + api.get(s.path() + "/camera", s.token).header(kETag);
  CHECK(api.send("PATCH", s.path() + "/camera", R"({"fovY": 53})", conditional(s, weak),
                 "application/json").status == 412);

  // Every edit route of the operation table refuses a stale tag before it reads the body or
  // looks for the thing it names, and leaves the session as it was.
  const std::string current = api.get(s.path(), s.token).header(kETag);
  std::set<std::string> tried;
  for (const protocol::Operation& op : protocol::operations()) {
    if (op.method == "GET" || !std::string_view(op.route).starts_with("/v1/sessions/{id}")) {
      continue;
    }
    const std::string path = concretePath(op.route, s);
    const Reply reply = api.send(std::string(op.method), path, "{}", conditional(s, tag),
                                 "application/json");
    checkProblem(reply, 412, "precondition-failed", std::string(op.method) + " " + path);
    CHECK_MESSAGE(reply.header(kETag) == current, op.method, " ", op.route);
    tried.insert(std::string(op.method) + " " + std::string(op.route));
  }
  CHECK(tried.size() >= 20);
  CHECK(tried.contains("DELETE /v1/sessions/{id}"));
  CHECK(tried.contains("PATCH /v1/sessions/{id}/objects/{oid}"));
  CHECK(api.get(s.path(), s.token).status == 200);
  CHECK(api.get(s.path(), s.token).header(kETag) == current);

  // Without If-Match an edit applies to the latest version, as before.
  CHECK(api.patch(s.path() + "/camera", R"({"fovY": 60})", s.token).status == 200);
  CHECK(api.get(s.path() + "/camera", s.token).json.at("fovY") == 60);
}

TEST_CASE("conditional edits: of two clients racing with one tag, exactly one edit lands") {
  ServerProcess server({"--lights", "8"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient setup(server);
  TestSession s = createSession(setup);

  // Rounds of read-modify-write: each of 4 clients reads the light's intensity with its ETag and
  // writes intensity + 1 with If-Match; a 412 makes it read again. No increment is lost: the end
  // value counts every 2xx.
  const std::string light = s.path() + "/lights/1";
  Reply first = setup.get(light, s.token);
  REQUIRE(first.status == 200);
  const double start = first.json.at("intensity").get<double>();
  std::atomic<int> applied{0}, refused{0};
  std::vector<std::thread> clients;
  for (int c = 0; c < 4; ++c) {
    clients.emplace_back([&] {
      ApiClient api(server);
      for (int done = 0; done < 10;) {
        const Reply read = api.get(light, s.token);
        if (read.status != 200) return;
        json patch = {{"intensity", read.json.at("intensity").get<double>() + 1.0}};
        const Reply write = api.send("PATCH", light, patch.dump(),
                                     conditional(s, read.header(kETag)), "application/json");
        if (write.status == 200) {
          ++applied;
          ++done;
        } else if (write.status == 412) {
          ++refused;
        } else {
          return;
        }
      }
    });
  }
  for (std::thread& t : clients) t.join();
  CHECK(applied == 40);
  MESSAGE("412s while racing: ", refused.load());
  const double end = setup.get(light, s.token).json.at("intensity").get<double>();
  CHECK(end == doctest::Approx(start + 40.0));
}
