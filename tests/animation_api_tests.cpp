// Animation over the API against the real server (lavapipe, validation on): objects' clips, the
// scene clock (play, pause, seek, rate), ?time=T giving the same bytes on every call, streams of
// an animated scene, and hostile animation data refused with a 4xx naming it.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "gltf_builder.h"
#include "server_process.h"

using myriad::test::ApiClient;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using nlohmann::json;

namespace {

constexpr const char* kSimpleSkin = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A unit quad on node 0 sliding +x by 2 over 2 s (linear): node animation.
std::string slidingQuad(float nanAt = -1.0f) {
  myriad::test::GltfBuilder b;
  const int pos = b.positions({-0.5f, -0.5f, 0, 0.5f, -0.5f, 0, 0.5f, 0.5f, 0, -0.5f, 0.5f, 0});
  const int idx = b.accessor(std::vector<uint16_t>{0, 1, 2, 0, 2, 3}, "SCALAR", 5123, 6);
  const int in = b.floats({0, 2}, "SCALAR", 1);
  const float end = nanAt >= 0 ? std::numeric_limits<float>::quiet_NaN() : 2.0f;
  const int out = b.floats({0, 0, 0, end, 0, 0}, "VEC3", 3);
  b.nodes.push_back("{\"mesh\":0,\"name\":\"quad\"}");
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                     "},\"indices\":" + std::to_string(idx) + "}]}");
  b.animations.push_back(
      "{\"name\":\"slide\",\"samplers\":[{\"input\":" + std::to_string(in) +
      ",\"output\":" + std::to_string(out) +
      "}],\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"translation\"}}]}");
  return b.json();
}

json addAsset(ApiClient& api, const TestSession& s, const std::string& bytes,
              const std::string& name) {
  Reply r =
      api.post(s.path() + "/assets?filename=" + name, bytes, s.token, "application/octet-stream");
  INFO(r.body.substr(0, 400));
  REQUIRE(r.status == 201);
  return r.json;
}

std::string frameBytes(ApiClient& api, const TestSession& s, const std::string& query = "") {
  Reply r = api.get(s.path() + "/frame?format=png&width=160&height=90" + query, s.token);
  INFO(r.body.substr(0, 300));
  REQUIRE(r.status == 200);
  return r.body;
}

void setup(ApiClient& api, const TestSession& s) {
  REQUIRE(api.patch(s.path() + "/settings",
                    R"({"markers": false, "antialias": "none", "shadows": {"sun": false}})",
                    s.token)
              .status == 200);
  REQUIRE(api.patch(s.path() + "/objects/1", R"({"visible": false})", s.token).status == 200);
  // ?time= places animated lights too: without lights, a frame is the objects' pose alone.
  REQUIRE(api.del(s.path() + "/lights", s.token).status == 204);
  REQUIRE(
      api.put(
             s.path() + "/camera",
             R"({"eye": [0, 1, 6], "target": [0.5, 1, 0], "up": [0, 1, 0], "fovY": 50, "near": 0.1, "far": 100})",
             s.token)
          .status == 200);
}

}  // namespace

TEST_CASE("animation api: clips, the scene clock and ?time=T") {
  ServerProcess server({"--lights", "4"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession s = createSession(api);
  setup(api, s);

  const json quad = addAsset(api, s, slidingQuad(), "slide.gltf");
  const json skin = addAsset(api, s, readFile(kSimpleSkin), "simple_skin.gltf");
  Reply added =
      api.post(s.path() + "/objects",
               json{{"objects",
                     {{{"asset", quad["id"]}, {"transform", {{"translation", {-1.5, 1, 0}}}}},
                      {{"asset", skin["id"]}, {"transform", {{"translation", {1.5, 0, 0}}}}}}}}
                   .dump(),
               s.token);
  REQUIRE(added.status == 201);
  const uint64_t quadId = added.json["ids"][0], skinId = added.json["ids"][1];

  // Objects of animated assets say what they play: clip 0, looped, by default.
  Reply q = api.get(s.path() + "/objects/" + std::to_string(quadId), s.token);
  REQUIRE(q.status == 200);
  CHECK(q.json["animation"] ==
        json{{"clip", 0}, {"clipName", "slide"}, {"loop", true}, {"duration", 2.0}, {"clips", 1}});
  Reply k = api.get(s.path() + "/objects/" + std::to_string(skinId), s.token);
  CHECK(k.json["animation"]["duration"] == 5.5);
  // The built-in scene has no clips: no member.
  CHECK_FALSE(api.get(s.path() + "/objects/1", s.token).json.contains("animation"));

  // The clock runs from the session's start.
  Reply c = api.get(s.path() + "/clock", s.token);
  REQUIRE(c.status == 200);
  CHECK(c.json["playing"] == true);
  CHECK(c.json["rate"] == 1.0);
  CHECK(c.json["duration"] == 5.5);
  CHECK(c.json["time"].get<double>() > 0.0);

  // ?time=T: the same bytes every time; another time, other bytes.
  const std::string at1 = frameBytes(api, s, "&time=1");
  CHECK(frameBytes(api, s, "&time=1") == at1);
  const std::string at2 = frameBytes(api, s, "&time=2.5");
  CHECK(at2 != at1);
  CHECK(frameBytes(api, s, "&time=1") == at1);

  // Pause and seek: frames without ?time= show the clock's time, which no longer moves.
  Reply paused = api.patch(s.path() + "/clock", R"({"playing": false, "time": 1})", s.token);
  REQUIRE(paused.status == 200);
  CHECK(paused.json["time"] == 1.0);
  CHECK(paused.json["playing"] == false);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  CHECK(api.get(s.path() + "/clock", s.token).json["time"] == 1.0);
  CHECK(frameBytes(api, s) == at1);

  // Rate: play at 2x from 1 s; the clock is past 1 s a moment later, and pausing keeps the time.
  Reply fast = api.patch(s.path() + "/clock", R"({"playing": true, "rate": 2})", s.token);
  REQUIRE(fast.status == 200);
  CHECK(fast.json["rate"] == 2.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  Reply later = api.patch(s.path() + "/clock", R"({"playing": false})", s.token);
  const double reached = later.json["time"].get<double>();
  CHECK(reached >= 1.0 + 2 * 0.2);
  CHECK(reached < 1.0 + 2 * 5.0);
  CHECK(api.get(s.path() + "/clock", s.token).json["time"] == reached);

  // A clip by name, none (rest pose), and hold instead of loop (the skinned object hidden: it
  // still plays).
  REQUIRE(
      api.patch(s.path() + "/objects/" + std::to_string(skinId), R"({"visible": false})", s.token)
          .status == 200);
  Reply held = api.patch(s.path() + "/objects/" + std::to_string(quadId),
                         R"({"animation": {"clipName": "slide", "loop": false}})", s.token);
  REQUIRE(held.status == 200);
  CHECK(held.json["animation"]["loop"] == false);
  const std::string heldAt3 = frameBytes(api, s, "&time=3");
  CHECK(frameBytes(api, s, "&time=2") != at1);
  CHECK(frameBytes(api, s, "&time=4") == heldAt3);  // held at its last key, 2 s
  Reply rest = api.patch(s.path() + "/objects/" + std::to_string(quadId),
                         R"({"animation": {"clip": null}})", s.token);
  REQUIRE(rest.status == 200);
  CHECK(rest.json["animation"]["clip"].is_null());

  // Mistakes name the member.
  const std::string quadPath = s.path() + "/objects/" + std::to_string(quadId);
  Reply walk = api.patch(quadPath, R"({"animation": {"clipName": "walk"}})", s.token);
  checkProblem(walk, 400, "invalid-body", "unknown clip name", "/animation/clipName");
  CHECK(walk.json.value("detail", "").find("walk") != std::string::npos);
  Reply noClip = api.patch(quadPath, R"({"animation": {"clip": 3}})", s.token);
  checkProblem(noClip, 400, "invalid-body", "clip index past the asset's", "/animation/clip");
  CHECK(noClip.json.value("detail", "").find("no clip 3") != std::string::npos);
  checkProblem(api.patch(s.path() + "/clock", R"({"rate": 1000})", s.token), 400, "invalid-body",
               "rate past 64", "/rate");
  checkProblem(api.patch(s.path() + "/clock", R"({"time": -1})", s.token), 400, "invalid-body",
               "negative time", "/time");

  // Hostile animation data: a NaN key is a 422 naming it, and the session keeps rendering.
  Reply nan = api.post(s.path() + "/assets?filename=nan.gltf", slidingQuad(1.0f), s.token,
                       "application/octet-stream");
  checkProblem(nan, 422, "model-rejected", "NaN key");
  CHECK(nan.json.value("detail", "").find("non-finite key") != std::string::npos);
  CHECK(frameBytes(api, s, "&time=1").size() > 0);
  CHECK(myriad::test::validationMessages(api) == 0);
}

namespace {

// Two quads: "left" at x = -2 and "right" at x = +2 with a child "tip" one unit above it.
std::string twoNodeModel() {
  myriad::test::GltfBuilder b;
  const int pos = b.positions({-0.5f, -0.5f, 0, 0.5f, -0.5f, 0, 0.5f, 0.5f, 0, -0.5f, 0.5f, 0});
  const int idx = b.accessor(std::vector<uint16_t>{0, 1, 2, 0, 2, 3}, "SCALAR", 5123, 6);
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                     "},\"indices\":" + std::to_string(idx) + "}]}");
  b.nodes.push_back("{\"name\":\"left\",\"mesh\":0,\"translation\":[-2,0,0]}");
  b.nodes.push_back("{\"name\":\"right\",\"mesh\":0,\"translation\":[2,0,0],\"children\":[2]}");
  b.nodes.push_back("{\"name\":\"tip\",\"mesh\":0,\"translation\":[0,1,0]}");
  b.sceneNodes = "[0,1]";
  return b.json();
}

}  // namespace

TEST_CASE("animation api: an object of one asset node draws that node's part") {
  ServerProcess server({"--lights", "4"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession s = createSession(api);
  const json asset = addAsset(api, s, twoNodeModel(), "two.gltf");
  CHECK(asset["instances"] == 3);
  Reply added = api.post(s.path() + "/objects",
                         json{{"objects",
                               {{{"asset", asset["id"]}},
                                {{"asset", asset["id"]}, {"nodeName", "right"}},
                                {{"asset", asset["id"]},
                                 {"nodeName", "right"},
                                 {"transform", {{"translation", {0, 0, 5}}}}}}}}
                             .dump(),
                         s.token);
  REQUIRE(added.status == 201);
  const std::string whole =
      s.path() + "/objects/" + std::to_string(added.json["ids"][0].get<int>());
  const std::string part = s.path() + "/objects/" + std::to_string(added.json["ids"][1].get<int>());
  const std::string moved =
      s.path() + "/objects/" + std::to_string(added.json["ids"][2].get<int>());
  CHECK(api.get(whole, s.token).json["instances"] == 3);
  Reply p = api.get(part, s.token);
  REQUIRE(p.status == 200);
  CHECK(p.json["instances"] == 2);  // right and its child tip
  CHECK(p.json["nodeName"] == "right");
  // Placed relative to the node: right's quad about the origin, tip one unit up.
  CHECK(p.json["bounds"]["min"] == json{-0.5, -0.5, 0.0});
  CHECK(p.json["bounds"]["max"] == json{0.5, 1.5, 0.0});
  CHECK(api.get(moved, s.token).json["bounds"]["min"] == json{-0.5, -0.5, 5.0});
  // By index (Assimp puts a "ROOT" node 0 above the file's two roots: left is 1); then back
  // to the whole asset.
  Reply left = api.patch(part, R"({"node": 1})", s.token);
  REQUIRE(left.status == 200);
  CHECK(left.json["instances"] == 1);
  CHECK(left.json["nodeName"] == "left");
  Reply all = api.patch(part, R"({"node": null})", s.token);
  CHECK(all.json["instances"] == 3);
  CHECK_FALSE(all.json.contains("node"));
  checkProblem(api.patch(part, R"({"nodeName": "nowhere"})", s.token), 400, "invalid-body",
               "unknown node", "/nodeName");
  // A snapshot keeps the node (and each object's clip): PUT back, the object is the part again.
  REQUIRE(api.patch(part, R"({"nodeName": "tip"})", s.token).status == 200);
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  REQUIRE(api.patch(part, R"({"node": null})", s.token).status == 200);
  Reply restored = api.put(s.path() + "/snapshot", snapshot.body, s.token);
  INFO(restored.body.substr(0, 300));
  REQUIRE(restored.status == 200);
  Reply back = api.get(part, s.token);
  CHECK(back.json["nodeName"] == "tip");
  CHECK(back.json["instances"] == 1);
  checkProblem(api.patch(part, R"({"node": 9})", s.token), 400, "invalid-body",
               "node past the tree", "/node");
  CHECK(frameBytes(api, s).size() > 0);
  CHECK(myriad::test::validationMessages(api) == 0);
}

TEST_CASE("animation api: a stream advances with the playing clock and rests when it pauses") {
  ServerProcess server({"--lights", "0"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession s = createSession(api);
  setup(api, s);
  const json quad = addAsset(api, s, slidingQuad(), "slide.gltf");
  REQUIRE(
      api.post(s.path() + "/objects", json{{"objects", {{{"asset", quad["id"]}}}}}.dump(), s.token)
          .status == 201);
  auto framesIn = [&](std::chrono::seconds window) {
    myriad::test::MultipartReader reader(server,
                                         s.path() + "/stream?format=jpeg&fps=10&width=64&height=36",
                                         myriad::test::bearer(s.token));
    REQUIRE(reader.status() == 200);
    REQUIRE(reader.waitFor(1, std::chrono::seconds(60)).size() >= 1);
    const size_t first = reader.items().size();
    std::this_thread::sleep_for(window);
    return reader.items().size() - first;
  };
  // Playing: nothing changes in the session, yet frames keep coming (the pose moves).
  const size_t playing = framesIn(std::chrono::seconds(3));
  // Paused: only the stream's own keep-alive frame every 2 s.
  REQUIRE(api.patch(s.path() + "/clock", R"({"playing": false})", s.token).status == 200);
  const size_t paused = framesIn(std::chrono::seconds(3));
  MESSAGE("frames in 3 s: " << playing << " playing, " << paused << " paused");
  CHECK(playing >= 5);
  CHECK(paused <= 2);
  CHECK(myriad::test::validationMessages(api) == 0);
}
