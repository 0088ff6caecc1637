// Shared sessions over loopback against the real server: viewer tokens (read and watch, never
// change; kept hashed; surviving a restart), two streams of one session sharing their renders
// (counted), and picking a light by its marker among all of a session's lights.
#include <doctest/doctest.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "encode/png.h"
#include "server_process.h"

using nlohmann::json;
using myriad::test::ApiClient;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using myriad::test::checkProblem;
using myriad::test::createSession;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

void requireListening(ServerProcess& server) {
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The X-Myriad-Frame numbers and bodies of a stream's parts, read on a thread of its own.
class PartCounter {
 public:
  PartCounter(const ServerProcess& server, const std::string& path, httplib::Headers headers)
      : client_(server.host(), server.port()) {
    client_.set_read_timeout(300, 0);
    thread_ = std::thread([this, path, headers] {
      client_.Get(path, headers, [this](const char* data, size_t size) {
        std::lock_guard lock(mutex_);
        buffer_.append(data, size);
        parse();
        changed_.notify_all();
        return !stop_;
      });
      std::lock_guard lock(mutex_);
      ended_ = true;
      changed_.notify_all();
    });
  }
  ~PartCounter() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    client_.stop();
    thread_.join();
  }

  // The frame numbers of the parts so far, once `frames` distinct ones arrived (or timeout).
  std::vector<std::string> waitForFrames(size_t frames, std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return distinct() >= frames || ended_; });
    return numbers_;
  }
  std::vector<std::string> bodies() {
    std::lock_guard lock(mutex_);
    return bodies_;
  }

 private:
  size_t distinct() const { return std::set<std::string>(numbers_.begin(), numbers_.end()).size(); }
  void parse() {
    static const std::regex header("X-Myriad-Frame: ([0-9]+)\r\n\r\n");
    for (;;) {
      const size_t length = buffer_.find("Content-Length: ", consumed_);
      const size_t end = buffer_.find("\r\n\r\n", consumed_);
      if (length == std::string::npos || end == std::string::npos) return;
      const size_t bytes = std::stoul(buffer_.substr(length + 16));
      if (buffer_.size() < end + 4 + bytes) return;
      std::smatch m;
      const std::string head = buffer_.substr(consumed_, end + 4 - consumed_);
      if (std::regex_search(head, m, header)) numbers_.push_back(m[1]);
      bodies_.push_back(buffer_.substr(end + 4, bytes));
      consumed_ = end + 4 + bytes;
    }
  }

  httplib::Client client_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::string buffer_;
  size_t consumed_ = 0;
  std::vector<std::string> numbers_;
  std::vector<std::string> bodies_;
  bool ended_ = false;
  bool stop_ = false;
};

json statsOf(ApiClient& api, const TestSession& s) {
  Reply stats = api.get(s.path() + "/stats", s.token);
  REQUIRE(stats.status == 200);
  return stats.json;
}

}  // namespace

TEST_CASE("shared sessions: a viewer token reads and watches, cannot change; kept hashed across a restart") {
  char dirTemplate[] = "/tmp/myriad-viewers-XXXXXX";
  REQUIRE(mkdtemp(dirTemplate) != nullptr);
  const fs::path stateDir = dirTemplate;
  const std::vector<std::string> args = {"--lights", "8", "--state-dir", stateDir.string()};
  TestSession s;
  std::string viewer;
  {
    ServerProcess server(args);
    requireListening(server);
    ApiClient api(server);
    s = createSession(api);
    Reply minted = api.post(s.path() + "/tokens", R"({"role": "viewer", "ttlSeconds": 600})", s.token);
    REQUIRE(minted.status == 201);
    viewer = minted.json.at("token").get<std::string>();
    CHECK(std::regex_match(viewer, std::regex("[0-9a-f]{64}")));
    CHECK(viewer != s.token);
    CHECK(minted.json.at("role") == "viewer");
    CHECK(minted.json.at("expiresInSeconds") == 600);
    CHECK(minted.json.at("link") == "/#session=" + s.id + "&token=" + viewer);

    // Reading and watching work with it.
    CHECK(api.get(s.path(), viewer).status == 200);
    CHECK(api.get(s.path() + "/lights?limit=3", viewer).json.at("total") == 8);
    CHECK(api.get(s.path() + "/camera", viewer).status == 200);
    Reply frame = api.get(s.path() + "/frame?width=64&height=48&format=png&token=" + viewer);
    CHECK(frame.status == 200);
    CHECK(frame.header("Content-Type") == "image/png");
    // Every change is 403 with a problem that says why, and changes nothing.
    checkProblem(api.patch(s.path() + "/camera", R"({"fovY": 20})", viewer), 403, "forbidden",
                 "viewer camera");
    CHECK(api.get(s.path() + "/camera", s.token).json.at("fovY") != 20);
    Reply refused = api.post(s.path() + "/lights/generate", R"({"count": 3, "seed": 2})", viewer);
    checkProblem(refused, 403, "forbidden", "viewer generate");
    CHECK(refused.json.at("detail").get<std::string>().find("viewer token") != std::string::npos);
    checkProblem(api.del(s.path() + "/lights/0", viewer), 403, "forbidden", "viewer delete light");
    checkProblem(api.del(s.path(), viewer), 403, "forbidden", "viewer delete session");
    checkProblem(api.post(s.path() + "/tokens", R"({"role": "viewer"})", viewer), 403, "forbidden",
                 "viewer mints");
    CHECK(api.get(s.path() + "/lights", s.token).json.at("total") == 8);
    // Bad requests for a token name what is wrong.
    checkProblem(api.post(s.path() + "/tokens", R"({"role": "owner"})", s.token), 400,
                 "invalid-body", "role owner", "/role");
    checkProblem(api.post(s.path() + "/tokens", R"({"role": "viewer", "ttlSeconds": 5})", s.token),
                 400, "invalid-body", "ttl", "/ttlSeconds");
    checkProblem(api.post(s.path() + "/tokens", "", s.token), 400, "invalid-body", "no body");
    // Another session's owner cannot mint one here; a viewer of this one is not a token there.
    TestSession other = createSession(api);
    checkProblem(api.post(s.path() + "/tokens", R"({"role": "viewer"})", other.token), 403,
                 "forbidden", "other owner");
    checkProblem(api.get(other.path(), viewer), 403, "forbidden", "viewer elsewhere");

    std::this_thread::sleep_for(std::chrono::milliseconds(600));  // written within 250 ms
    const std::string stored = readFile(stateDir / "sessions" / (s.id + ".json"));
    CHECK(stored.find(viewer) == std::string::npos);
    CHECK(stored.find("viewerTokens") != std::string::npos);
    const auto stopped = server.stop();
    REQUIRE(stopped.has_value());
    CHECK(stopped->cleanExit());
  }
  {
    // After a restart the viewer's first request restores the session (by the stored hash);
    // it still cannot change it, and the owner still can.
    ServerProcess server(args);
    requireListening(server);
    ApiClient api(server);
    Reply state = api.get(s.path(), viewer);
    INFO(server.stderrText().substr(0, 2000));
    REQUIRE(state.status == 200);
    checkProblem(api.patch(s.path() + "/settings", R"({"exposure": 2})", viewer), 403,
                 "forbidden", "viewer after restart");
    CHECK(api.patch(s.path() + "/settings", R"({"exposure": 2})", s.token).status == 200);
    // Revoked: the viewer's next request is 401.
    CHECK(api.del(s.path() + "/tokens", s.token).status == 204);
    checkProblem(api.get(s.path(), viewer), 401, "unauthorized", "revoked");
    CHECK(api.get(s.path(), s.token).status == 200);
    const auto stopped = server.stop();
    REQUIRE(stopped.has_value());
    CHECK(stopped->cleanExit());
  }
  fs::remove_all(stateDir);
}

TEST_CASE("shared sessions: an owner's and a viewer's stream of one session render each frame once") {
  ServerProcess server({"--lights", "32"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  Reply minted = api.post(s.path() + "/tokens", R"({"role": "viewer"})", s.token);
  REQUIRE(minted.status == 201);
  const std::string viewer = minted.json.at("token").get<std::string>();
  const std::string query = "/stream?format=jpeg&fps=10&width=96&height=64";
  const uint64_t framesBefore = statsOf(api, s).at("frames").get<uint64_t>();

  PartCounter owner(server, s.path() + query, {{"Authorization", "Bearer " + s.token}});
  PartCounter watcher(server, s.path() + query + "&token=" + viewer, {});
  REQUIRE(owner.waitForFrames(1, std::chrono::seconds(120)).size() >= 1);
  REQUIRE(watcher.waitForFrames(1, std::chrono::seconds(120)).size() >= 1);
  // Edits: each must reach both pages; the server renders each frame once for the two.
  constexpr int kEdits = 4;
  for (int i = 1; i <= kEdits; ++i) {
    REQUIRE(api.patch(s.path() + "/camera", json{{"fovY", 30 + 5 * i}}.dump(), s.token).status == 200);
    REQUIRE(owner.waitForFrames(size_t(i) + 1, std::chrono::seconds(120)).size() >= size_t(i) + 1);
    REQUIRE(watcher.waitForFrames(size_t(i) + 1, std::chrono::seconds(120)).size() >= size_t(i) + 1);
  }
  const uint64_t rendered = statsOf(api, s).at("frames").get<uint64_t>() - framesBefore;
  MESSAGE("two streams, ", kEdits + 1, " frames each: ", rendered, " renders");
  CHECK(rendered == kEdits + 1);  // not 2 * (kEdits + 1)
  // Both saw the same pictures: the last frame of each is the same encode.
  CHECK(owner.bodies().back() == watcher.bodies().back());
  Reply metrics = api.get("/metrics");
  std::smatch shared;
  REQUIRE(std::regex_search(metrics.body, shared,
                            std::regex("myriad_stream_frames_shared_total ([0-9]+)")));
  MESSAGE("stream parts from another stream's render: ", shared[1].str());
  CHECK(std::stoul(shared[1]) >= size_t(kEdits + 1));
}

TEST_CASE("shared sessions: the pick route finds the light under a marker among all lights") {
  // 5,000 lights in 320x240: one-pixel markers for every light (markers.glsl's budget).
  ServerProcess server({"--lights", "5000"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string size = "width=320&height=240";
  auto frame = [&](bool markers) {
    // Anti-aliasing (on by default) would smear markers' edges into pixels no marker covers.
    REQUIRE(api.patch(s.path() + "/settings", json{{"markers", markers}, {"antialias", "none"}}.dump(),
                      s.token).status == 200);
    Reply png = api.get(s.path() + "/frame?format=png&" + size, s.token);
    REQUIRE(png.status == 200);
    return myriad::encode::decodePng(
        {reinterpret_cast<const uint8_t*>(png.body.data()), png.body.size()});
  };
  const auto with = frame(true);
  const auto without = frame(false);
  REQUIRE(with.rgba.size() == without.rgba.size());
  // Every marker pixel (where the markers changed the picture) picks a light whose marker is there.
  std::vector<std::pair<int, int>> markerPixels;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      const size_t i = (size_t(y) * 320 + x) * 4;
      int d = 0;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(with.rgba[i + c]) - int(without.rgba[i + c])));
      if (d > 24) markerPixels.emplace_back(x, y);
    }
  }
  MESSAGE(markerPixels.size(), " marker pixels");
  REQUIRE(markerPixels.size() > 100);
  size_t picked = 0, beyondFirstPage = 0, tried = 0;
  for (size_t k = 0; k < markerPixels.size(); k += markerPixels.size() / 40) {
    const auto [x, y] = markerPixels[k];
    ++tried;
    Reply hit = api.get(s.path() + "/lights/pick?x=" + std::to_string(x) + "&y=" + std::to_string(y) +
                        "&" + size, s.token);
    REQUIRE(hit.status == 200);
    if (!hit.json.contains("light")) continue;
    ++picked;
    CHECK(hit.json.at("distance").get<double>() <= 0.75);
    const uint64_t id = hit.json.at("light").at("id").get<uint64_t>();
    if (id >= 1000) ++beyondFirstPage;
    CHECK(api.get(s.path() + "/lights/" + std::to_string(id), s.token).json == hit.json.at("light"));
  }
  MESSAGE(picked, " of ", tried, " marker pixels picked a light; ", beyondFirstPage, " beyond id 999");
  CHECK(picked == tried);
  CHECK(beyondFirstPage > 0);
  // Far from every marker: nothing. Off the frame, or without the size: 400 naming it.
  Reply none = api.get(s.path() + "/lights/pick?x=0&y=0&width=320&height=240", s.token);
  CHECK(none.status == 200);
  checkProblem(api.get(s.path() + "/lights/pick?x=400&y=10&" + size, s.token), 400,
               "invalid-parameter", "x off", std::nullopt, std::nullopt, "x");
  checkProblem(api.get(s.path() + "/lights/pick?x=1&y=1", s.token), 400, "invalid-parameter",
               "no size", std::nullopt, std::nullopt, "width");
  checkProblem(api.get(s.path() + "/lights/pick?x=1&y=1&radius=100&" + size, s.token), 400,
               "invalid-parameter", "radius", std::nullopt, std::nullopt, "radius");
  checkProblem(api.get(s.path() + "/lights/pick?x=a&y=1&" + size, s.token), 400,
               "invalid-parameter", "x text", std::nullopt, std::nullopt, "x");
  checkProblem(api.get(s.path() + "/lights/pick?x=1&y=1&z=2&" + size, s.token), 400,
               "unknown-parameter", "z", std::nullopt, std::nullopt, "z");
}
