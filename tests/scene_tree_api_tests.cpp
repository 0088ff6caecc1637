// Scenes that last and scenes with structure, against the real server (lavapipe, validation on):
// a scene of uploaded assets and objects survives a SIGKILL and restart with --state-dir (the same
// frame, byte for byte, and the same objects); a glTF's node tree loaded by PUT .../model is one
// object per node under one root, and moving a parent node's object moves its child's pixels;
// semantic classes given by name map to stable per-session ids (labels, the semantic-id target,
// snapshots). service/scene_graph.h, state_store.h, api_sessions.cpp.
#include <doctest/doctest.h>
#include <signal.h>
#include <stdlib.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
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

namespace fs = std::filesystem;

constexpr const char* kSpider = "/usr/share/assimp/models/OBJ/spider.obj";
constexpr const char* kBox = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";
constexpr int kWidth = 128, kHeight = 96;

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

// A unit quad "body" at (-1, 1, 0) with a child quad "arm" two units to its right (glTF's node
// tree: the child's translation is relative to its parent).
std::string parentChildModel() {
  myriad::test::GltfBuilder b;
  const int pos = b.positions({-0.5f, -0.5f, 0, 0.5f, -0.5f, 0, 0.5f, 0.5f, 0, -0.5f, 0.5f, 0});
  const int idx = b.accessor(std::vector<uint16_t>{0, 1, 2, 0, 2, 3}, "SCALAR", 5123, 6);
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                     "},\"indices\":" + std::to_string(idx) + "}]}");
  b.nodes.push_back("{\"name\":\"body\",\"mesh\":0,\"translation\":[-1,1,0],\"children\":[1]}");
  b.nodes.push_back("{\"name\":\"arm\",\"mesh\":0,\"translation\":[2,0,0]}");
  b.sceneNodes = "[0]";
  return b.json();
}

json addAsset(ApiClient& api, const TestSession& s, const std::string& bytes,
              const std::string& filename) {
  Reply r = api.post(s.path() + "/assets?filename=" + filename, bytes, s.token,
                     "application/octet-stream");
  INFO(r.body.substr(0, 400));
  REQUIRE(r.status == 201);
  return r.json;
}

std::vector<uint32_t> addObjects(ApiClient& api, const TestSession& s, const json& objects) {
  Reply r = api.post(s.path() + "/objects", json{{"objects", objects}}.dump(), s.token);
  INFO(r.body.substr(0, 400));
  REQUIRE(r.status == 201);
  return r.json.at("ids").get<std::vector<uint32_t>>();
}

// No sun shadow, markers or antialiasing; one listed light (generated ones are re-made around
// the model on a restore); a camera looking at the origin from +z.
void plainScene(ApiClient& api, const TestSession& s) {
  REQUIRE(api.patch(s.path() + "/settings",
                    R"({"markers": false, "antialias": "none", "shadows": {"sun": false}})", s.token)
              .status == 200);
  REQUIRE(api.del(s.path() + "/lights", s.token).status == 204);
  REQUIRE(api.post(s.path() + "/lights",
                   R"({"lights": [{"position": [0, 2, 2], "radius": 8, "color": [1, 0.9, 0.8], "intensity": 4, "falloff": 1}]})",
                   s.token)
              .status == 201);
  REQUIRE(api.put(s.path() + "/camera",
                  R"({"eye": [0, 1, 6], "target": [0, 1, 0], "up": [0, 1, 0], "fovY": 50, "near": 0.1, "far": 100})",
                  s.token)
              .status == 200);
}

std::string frameQuery(const std::string& extra = "") {
  return "/frame?width=" + std::to_string(kWidth) + "&height=" + std::to_string(kHeight) + extra;
}

// A raw uint32 target (instance-id, semantic-id) of the session's view.
std::vector<uint32_t> rawIds(ApiClient& api, const TestSession& s, const std::string& target) {
  Reply r = api.get(s.path() + frameQuery("&format=raw&target=" + target), s.token);
  INFO(r.body.substr(0, 300));
  REQUIRE(r.status == 200);
  REQUIRE(r.body.size() == size_t(kWidth) * kHeight * 4);
  std::vector<uint32_t> ids(size_t(kWidth) * kHeight);
  std::memcpy(ids.data(), r.body.data(), r.body.size());
  return ids;
}

// The mean column of the pixels showing object `id` (-1 when none does), and how many there are.
std::pair<double, size_t> columnOf(const std::vector<uint32_t>& ids, uint32_t id) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t p = 0; p < ids.size(); ++p) {
    if (ids[p] != id) continue;
    sum += double(p % kWidth);
    ++n;
  }
  return {n > 0 ? sum / double(n) : -1.0, n};
}

// The session's state file, once it holds `objects` objects and `assets` asset uploads (the
// persister writes within a quarter of a second; a loaded machine may take longer).
json waitForRecord(const fs::path& file, size_t objects, size_t assets) {
  json record;
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!fs::exists(file)) continue;
    record = json::parse(readFile(file), nullptr, false);
    if (record.is_discarded() || !record.contains("snapshot")) continue;
    const json& scene = record["snapshot"].value("scene", json::object());
    if (scene.value("objects", json::array()).size() == objects &&
        record.value("assets", json::array()).size() == assets) {
      return record;
    }
  }
  FAIL("the state file never held the scene: " << record.dump().substr(0, 600));
  return record;
}

}  // namespace

TEST_CASE("scene: --state-dir keeps uploaded assets, objects and classes; SIGKILL and restart give the same frame") {
  char dirTemplate[] = "/tmp/myriad-scene-state-XXXXXX";
  REQUIRE(mkdtemp(dirTemplate) != nullptr);
  const fs::path stateDir = dirTemplate;
  const std::vector<std::string> args = {"--lights", "4", "--state-dir", stateDir.string()};
  TestSession s;
  std::string framePng, labels;
  json objects, assets;
  std::vector<uint32_t> ids;
  {
    ServerProcess first(args);
    requireListening(first);
    ApiClient api(first);
    s = createSession(api);
    // The model: a node tree of two (its own objects 2 and 3); then two uploaded assets.
    REQUIRE(api.put(s.path() + "/model?filename=tree.gltf&lights=keep", parentChildModel(), s.token,
                    "application/octet-stream")
                .status == 200);
    plainScene(api, s);
    const json box = addAsset(api, s, readFile(kBox), "box.glb");
    const json spider = addAsset(api, s, readFile(kSpider), "spider.obj");
    ids = addObjects(
        api, s,
        json::array(
            {{{"asset", box["id"]}, {"name", "car"}, {"semantic", "car"},
              {"transform", {{"translation", {0, 0.3, 1}}, {"scale", {0.5, 0.5, 0.5}}}}},
             {{"asset", box["id"]}, {"name", "on the car"}, {"semantic", 7},
              {"transform", {{"translation", {0, 1, 0}}, {"scale", {0.5, 0.5, 0.5}}}}},
             {{"asset", spider["id"]}, {"name", "hidden spider"}, {"visible", false},
              {"transform", {{"translation", {1, 0, 0}}, {"scale", {0.01, 0.01, 0.01}}}}},
             {{"asset", spider["id"]}, {"name", "spider"}, {"semantic", "pet"}, {"material", 0},
              {"transform",
               {{"translation", {1.2, 0.2, 1}}, {"rotation", {0, 0.3826834, 0, 0.9238795}},
                {"scale", {0.01, 0.01, 0.01}}}}}}));
    REQUIRE(ids.size() == 4);
    // The second box rides on the first.
    REQUIRE(api.patch(s.path() + "/objects/" + std::to_string(ids[1]),
                      json{{"parent", ids[0]}}.dump(), s.token)
                .status == 200);
    // The model's child node (object 3, under the root object 2) moved on its own.
    REQUIRE(api.patch(s.path() + "/objects/3", R"({"transform": {"translation": [2, -0.2, 0]}})",
                      s.token)
                .status == 200);
    Reply frame = api.get(s.path() + frameQuery("&format=png"), s.token);
    REQUIRE(frame.status == 200);
    framePng = frame.body;
    Reply list = api.get(s.path() + "/objects?limit=100", s.token);
    REQUIRE(list.status == 200);
    objects = list.json;
    CHECK(objects["total"] == 6);
    assets = api.get(s.path() + "/assets", s.token).json;
    REQUIRE(assets["assets"].size() == 3);
    Reply l = api.get(s.path() + "/labels" + frameQuery().substr(6), s.token);
    REQUIRE(l.status == 200);
    labels = l.body;
    CHECK(l.json["classes"] == json::parse(R"([{"name": "car", "id": 1}, {"name": "pet", "id": 2}])"));
    // The record names both asset uploads (the model's is its own member), and their blobs.
    const json record = waitForRecord(stateDir / "sessions" / (s.id + ".json"), 6, 2);
    CHECK(record.contains("upload"));
    for (const json& upload : record["assets"]) {
      CHECK(fs::exists(stateDir / "blobs" / upload["blob"].get<std::string>()));
    }
    CHECK(myriad::test::validationMessages(api) == 0);
    first.signal(SIGKILL);
    REQUIRE(first.waitForExit(std::chrono::seconds(30)).has_value());
  }
  {
    ServerProcess second(args);
    requireListening(second);
    ApiClient api(second);
    Reply frame = api.get(s.path() + frameQuery("&format=png"), s.token);
    INFO(second.stderrText().substr(0, 3000));
    REQUIRE(frame.status == 200);
    CHECK(second.stderrText().find("session " + s.id + " restored") != std::string::npos);
    CHECK(frame.body == framePng);
    CHECK(api.get(s.path() + "/objects?limit=100", s.token).json == objects);
    CHECK(api.get(s.path() + "/assets", s.token).json == assets);
    CHECK(api.get(s.path() + "/labels" + frameQuery().substr(6), s.token).body == labels);
    // The names keep their ids, and the next object id goes on where it was.
    Reply car = api.get(s.path() + "/objects/" + std::to_string(ids[0]), s.token);
    CHECK(car.json["semantic"] == "car");
    const std::vector<uint32_t> more =
        addObjects(api, s, json::array({{{"asset", objects["objects"][0]["asset"]},
                                         {"semantic", "car"}},
                                        {{"asset", objects["objects"][0]["asset"]},
                                         {"semantic", "truck"}}}));
    CHECK(more == std::vector<uint32_t>{ids[3] + 1, ids[3] + 2});
    Reply classes = api.get(s.path() + "/labels" + frameQuery().substr(6), s.token);
    // 7 is an object's integer: "truck" takes the lowest id free of both.
    CHECK(classes.json["classes"] ==
          json::parse(R"([{"name": "car", "id": 1}, {"name": "pet", "id": 2}, {"name": "truck", "id": 3}])"));
    CHECK(myriad::test::validationMessages(api) == 0);
    std::optional<myriad::test::ExitStatus> status = second.stop();
    REQUIRE(status.has_value());
    CHECK(status->cleanExit());
  }
  {
    // A record whose asset upload is hostile is refused (treated as absent), with one log line.
    const fs::path file = stateDir / "sessions" / (s.id + ".json");
    json record = json::parse(readFile(file));
    REQUIRE(record["assets"].size() == 2);
    record["assets"][1]["blob"] = "../../etc/passwd";
    std::ofstream(file.string() + ".test", std::ios::binary) << record.dump();
    fs::rename(file.string() + ".test", file);
    ServerProcess third(args);
    requireListening(third);
    ApiClient api(third);
    checkProblem(api.get(s.path(), s.token), 404, "not-found", "hostile asset upload");
    CHECK(third.stderrText().find("/assets/1/blob") != std::string::npos);
    third.stop();
  }
  fs::remove_all(stateDir);
}

TEST_CASE("scene: a glTF node tree is one object per node under one root; a parent's move moves its child") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  Reply put = api.put(s.path() + "/model?filename=tree.gltf", parentChildModel(), s.token,
                      "application/octet-stream");
  INFO(put.body.substr(0, 400));
  REQUIRE(put.status == 200);
  plainScene(api, s);

  // The built-in scene was object 1: the tree is objects 2 (root, node "body") and 3 (its child).
  Reply list = api.get(s.path() + "/objects", s.token);
  REQUIRE(list.status == 200);
  REQUIRE(list.json["total"] == 2);
  const json& root = list.json["objects"][0];
  const json& arm = list.json["objects"][1];
  CHECK(root["id"] == 2);
  CHECK(root["name"] == "upload:tree.gltf");
  CHECK(root["parent"].is_null());
  CHECK(root["nodeName"] == "body");
  CHECK(root["subtree"] == false);
  CHECK(root["instances"] == 1);
  CHECK(root["transform"]["translation"] == json{-1.0, 1.0, 0.0});
  CHECK(arm["id"] == 3);
  CHECK(arm["parent"] == 2);
  CHECK(arm["nodeName"] == "arm");
  CHECK(arm["instances"] == 1);
  // Its local transform, as the file has it; placed in the world under its parent.
  CHECK(arm["transform"]["translation"] == json{2.0, 0.0, 0.0});
  CHECK(arm["bounds"]["min"] == json{0.5, 0.5, 0.0});
  CHECK(arm["bounds"]["max"] == json{1.5, 1.5, 0.0});

  const std::vector<uint32_t> before = rawIds(api, s, "instance-id");
  const auto [bodyColumn, bodyPixels] = columnOf(before, 2);
  const auto [armColumn, armPixels] = columnOf(before, 3);
  REQUIRE(bodyPixels > 50);
  REQUIRE(armPixels > 50);
  CHECK(armColumn > bodyColumn);

  // The parent moves 0.5 to the right: so does its child, by as many pixels.
  Reply moved =
      api.patch(s.path() + "/objects/2", R"({"transform": {"translation": [-0.5, 1, 0]}})", s.token);
  REQUIRE(moved.status == 200);
  CHECK(api.get(s.path() + "/objects/3", s.token).json["bounds"]["min"] == json{1.0, 0.5, 0.0});
  const std::vector<uint32_t> after = rawIds(api, s, "instance-id");
  const auto [bodyColumn2, bodyPixels2] = columnOf(after, 2);
  const auto [armColumn2, armPixels2] = columnOf(after, 3);
  MESSAGE("body column " << bodyColumn << " -> " << bodyColumn2 << ", arm column " << armColumn
                         << " -> " << armColumn2);
  // As many pixels (but for the rows and columns a sub-pixel shift adds or drops), as far.
  CHECK(double(armPixels2) == doctest::Approx(double(armPixels)).epsilon(0.15));
  CHECK(double(bodyPixels2) == doctest::Approx(double(bodyPixels)).epsilon(0.15));
  // 0.5 units at 6 units away with a 50 degree field of view: 0.5 / (2 * 6 * tan 25) * 96 px =
  // 8.6 px; pixel centres make each quad's mean column move by 8 or 9.
  CHECK(std::abs((armColumn2 - armColumn) - (bodyColumn2 - bodyColumn)) <= 1.0);
  CHECK(armColumn2 - armColumn == doctest::Approx(8.6).epsilon(0.12));
  CHECK(bodyColumn2 - bodyColumn == doctest::Approx(8.6).epsilon(0.12));

  // The child alone: the parent stays.
  REQUIRE(api.patch(s.path() + "/objects/3", R"({"transform": {"translation": [2, 1, 0]}})", s.token)
              .status == 200);
  const std::vector<uint32_t> raised = rawIds(api, s, "instance-id");
  CHECK(columnOf(raised, 2).first == bodyColumn2);
  // Hiding the root hides the tree; deleting it deletes the tree.
  REQUIRE(api.patch(s.path() + "/objects/2", R"({"visible": false})", s.token).status == 200);
  const std::vector<uint32_t> hidden = rawIds(api, s, "instance-id");
  CHECK(columnOf(hidden, 2).second == 0);
  CHECK(columnOf(hidden, 3).second == 0);
  REQUIRE(api.del(s.path() + "/objects/2", s.token).status == 204);
  CHECK(api.get(s.path() + "/objects", s.token).json["total"] == 0);

  // A model with one node of meshes stays one object (PUT .../model as before).
  REQUIRE(api.put(s.path() + "/model?filename=box.glb", readFile(kBox), s.token,
                  "application/octet-stream")
              .status == 200);
  Reply single = api.get(s.path() + "/objects", s.token);
  CHECK(single.json["total"] == 1);
  CHECK_FALSE(single.json["objects"][0].contains("node"));
  CHECK(myriad::test::validationMessages(api) == 0);
}

TEST_CASE("scene: POST .../objects with tree makes an asset's node tree of objects, placed and labelled as asked") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  plainScene(api, s);
  REQUIRE(api.del(s.path() + "/objects/1", s.token).status == 204);  // the built-in scene
  const std::string aid = addAsset(api, s, parentChildModel(), "tree.gltf")["id"];

  // One item, two objects: the root node's ("body", the item's name and class) and its child's.
  const std::vector<uint32_t> ids =
      addObjects(api, s, json::array({{{"asset", aid}, {"tree", true}, {"name", "robot"},
                                       {"semantic", "robot"}}}));
  REQUIRE(ids == std::vector<uint32_t>{2, 3});
  const json root = api.get(s.path() + "/objects/2", s.token).json;
  const json arm = api.get(s.path() + "/objects/3", s.token).json;
  CHECK(root["name"] == "robot");
  CHECK(root["nodeName"] == "body");
  CHECK(root["parent"].is_null());
  CHECK(root["transform"]["translation"] == json{-1.0, 1.0, 0.0});  // the node's own, kept
  CHECK(arm["nodeName"] == "arm");
  CHECK(arm["parent"] == 2);
  CHECK(root["semantic"] == "robot");
  CHECK(arm["semantic"] == "robot");
  CHECK(arm["bounds"]["min"] == json{0.5, 0.5, 0.0});
  const std::vector<uint32_t> first = rawIds(api, s, "instance-id");
  const auto [bodyColumn, bodyPixels] = columnOf(first, 2);
  const auto [armColumn, armPixels] = columnOf(first, 3);
  REQUIRE(bodyPixels > 50);
  REQUIRE(armPixels > 50);
  CHECK(armColumn > bodyColumn);

  // A second tree moved 0.5 to the right: on top of the root node's own transform, so both of
  // its objects land 0.5 right of the first tree's (bounds, and about 8.6 px on screen).
  const std::vector<uint32_t> moved = addObjects(
      api, s, json::array({{{"asset", aid}, {"tree", true},
                            {"transform", {{"translation", {0.5, 0, 0}}}}}}));
  REQUIRE(moved == std::vector<uint32_t>{4, 5});
  CHECK(api.get(s.path() + "/objects/4", s.token).json["bounds"]["min"] == json{-1.0, 0.5, 0.0});
  CHECK(api.get(s.path() + "/objects/5", s.token).json["bounds"]["min"] == json{1.0, 0.5, 0.0});
  REQUIRE(api.patch(s.path() + "/objects/2", R"({"visible": false})", s.token).status == 200);
  const std::vector<uint32_t> second = rawIds(api, s, "instance-id");
  CHECK(columnOf(second, 2).second == 0);
  CHECK(columnOf(second, 3).second == 0);  // hidden with its root
  CHECK(columnOf(second, 4).first - bodyColumn == doctest::Approx(8.6).epsilon(0.12));
  CHECK(columnOf(second, 5).first - armColumn == doctest::Approx(8.6).epsilon(0.12));

  // Refused, nothing added: with a node; an asset of one drawn node; and a later item's bad
  // parent is blamed on that item (1), not on its place among the objects the tree made (2).
  const std::string box = addAsset(api, s, readFile(kBox), "box.glb")["id"];
  const auto refused = [&](const json& items, const std::string& pointer) {
    Reply r = api.post(s.path() + "/objects", json{{"objects", items}}.dump(), s.token);
    INFO(r.body.substr(0, 400));
    checkProblem(r, 400, "invalid-body", "POST .../objects", pointer);
  };
  refused(json::array({{{"asset", aid}, {"tree", true}, {"node", 0}}}), "/objects/0/tree");
  refused(json::array({{{"asset", box}, {"tree", true}}}), "/objects/0/tree");
  refused(json::array({{{"asset", aid}, {"tree", true}}, {{"asset", aid}, {"parent", 999}}}),
          "/objects/1/parent");
  CHECK(api.get(s.path() + "/objects", s.token).json["total"] == 4);
  CHECK(myriad::test::validationMessages(api) == 0);
}

TEST_CASE("scene: semantic classes by name map to stable ids in labels, targets and snapshots") {
  ServerProcess server({"--lights", "4", "--max-objects", "50"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  plainScene(api, s);
  REQUIRE(api.patch(s.path() + "/objects/1", R"({"visible": false})", s.token).status == 200);
  const json box = addAsset(api, s, readFile(kBox), "box.glb");
  auto boxAt = [&](double x, const json& semantic) {
    return json{{"asset", box["id"]},
                {"semantic", semantic},
                {"transform", {{"translation", {x, 1, 0}}, {"scale", {0.6, 0.6, 0.6}}}}};
  };
  // An integer given in the same request is taken: the names get the lowest ids free of it.
  const std::vector<uint32_t> ids = addObjects(
      api, s, json::array({boxAt(-1.5, "car"), boxAt(-0.5, 1), boxAt(0.5, "person"), boxAt(1.5, "car")}));
  REQUIRE(ids.size() == 4);
  Reply first = api.get(s.path() + "/objects/" + std::to_string(ids[0]), s.token);
  CHECK(first.json["semantic"] == "car");
  CHECK(api.get(s.path() + "/objects/" + std::to_string(ids[1]), s.token).json["semantic"] == 1);

  Reply labels = api.get(s.path() + "/labels" + frameQuery().substr(6), s.token);
  REQUIRE(labels.status == 200);
  CHECK(labels.json["classes"] ==
        json::parse(R"([{"name": "car", "id": 2}, {"name": "person", "id": 3}])"));
  std::map<uint32_t, uint32_t> classOf = {{ids[0], 2}, {ids[1], 1}, {ids[2], 3}, {ids[3], 2}};
  size_t labelled = 0;
  for (const json& l : labels.json["objects"]) {
    const uint32_t id = l["id"];
    if (!classOf.contains(id)) continue;
    CHECK(l["semantic"] == classOf[id]);
    ++labelled;
  }
  CHECK(labelled == 4);
  // The semantic-id target holds the ids, pixel for pixel with the instance-id target.
  const std::vector<uint32_t> instance = rawIds(api, s, "instance-id");
  const std::vector<uint32_t> semantic = rawIds(api, s, "semantic-id");
  size_t checked = 0, wrong = 0;
  for (size_t p = 0; p < instance.size(); ++p) {
    const auto it = classOf.find(instance[p]);
    if (it == classOf.end()) continue;
    ++checked;
    wrong += semantic[p] != it->second ? 1 : 0;
  }
  CHECK(checked > 100);
  CHECK(wrong == 0);

  // A class keeps its id when no object uses it any more; a new name does not take it.
  REQUIRE(api.patch(s.path() + "/objects/" + std::to_string(ids[2]), R"({"semantic": 0})", s.token)
              .status == 200);
  Reply tree = api.patch(s.path() + "/objects/" + std::to_string(ids[2]), R"({"semantic": "tree"})",
                         s.token);
  REQUIRE(tree.status == 200);
  CHECK(tree.json["semantic"] == "tree");
  Reply after = api.get(s.path() + "/labels" + frameQuery().substr(6), s.token);
  CHECK(after.json["classes"] ==
        json::parse(R"([{"name": "car", "id": 2}, {"name": "person", "id": 3}, {"name": "tree", "id": 4}])"));

  // A snapshot carries the names and their ids: restored after edits, they are back as they were.
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json["scene"]["classes"] == after.json["classes"]);
  REQUIRE(api.patch(s.path() + "/objects/" + std::to_string(ids[0]), R"({"semantic": "bus"})", s.token)
              .status == 200);
  REQUIRE(api.put(s.path() + "/snapshot", snapshot.body, s.token).status == 200);
  CHECK(api.get(s.path() + "/snapshot", s.token).json == snapshot.json);
  CHECK(rawIds(api, s, "semantic-id") != semantic);  // "person" became "tree" (3 -> 4)

  // Hostile values are 400s naming the member; a snapshot's classes are checked too.
  const std::string objectPath = s.path() + "/objects/" + std::to_string(ids[0]);
  checkProblem(api.patch(objectPath, R"({"semantic": ""})", s.token), 400, "invalid-body",
               "empty class", "/semantic");
  checkProblem(api.patch(objectPath, json{{"semantic", std::string(65, 'x')}}.dump(), s.token), 400,
               "invalid-body", "long class", "/semantic");
  checkProblem(api.patch(objectPath, R"({"semantic": 65536})", s.token), 400, "invalid-body",
               "class past 16 bits", "/semantic");
  checkProblem(api.patch(objectPath, R"({"semantic": 2.5})", s.token), 400, "invalid-body",
               "fractional class", "/semantic");
  json twice = snapshot.json;
  twice["scene"]["classes"] = json::parse(R"([{"name": "car", "id": 2}, {"name": "van", "id": 2}])");
  checkProblem(api.put(s.path() + "/snapshot", twice.dump(), s.token), 400, "invalid-body",
               "an id twice", "/scene/classes/1");
  json zero = snapshot.json;
  zero["scene"]["classes"] = json::parse(R"([{"name": "car", "id": 0}])");
  checkProblem(api.put(s.path() + "/snapshot", zero.dump(), s.token), 400, "invalid-body",
               "class id 0", "/scene/classes/0/id");
  CHECK(api.get(s.path() + "/snapshot", s.token).json == snapshot.json);
  CHECK(myriad::test::validationMessages(api) == 0);
}

TEST_CASE("scene: POST .../objects/{oid}/duplicate copies an object and the objects below it") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  REQUIRE(api.put(s.path() + "/model?filename=tree.gltf", parentChildModel(), s.token,
                  "application/octet-stream")
              .status == 200);
  plainScene(api, s);
  // Objects 2 ("body", at (-1, 1, 0)) and 3 ("arm", its child, 2 units to its right).
  const std::vector<uint32_t> before = rawIds(api, s, "instance-id");
  const auto [bodyColumn, bodyPixels] = columnOf(before, 2);
  const auto [armColumn, armPixels] = columnOf(before, 3);
  REQUIRE(bodyPixels > 50);
  REQUIRE(armPixels > 50);

  // The body and its arm copied, the copy named and moved 1.5 units down: ids 4 (the body's
  // copy) and 5 (the arm's, under 4), parents first.
  Reply copied = api.post(s.path() + "/objects/2/duplicate",
                          R"({"name": "copy", "transform": {"translation": [-1, -0.5, 0]}})", s.token);
  INFO(copied.body.substr(0, 400));
  REQUIRE(copied.status == 201);
  CHECK(copied.json["ids"] == json{4, 5});
  CHECK(copied.json["total"] == 4);
  const json copy = api.get(s.path() + "/objects/4", s.token).json;
  CHECK(copy["name"] == "copy");
  CHECK(copy["parent"].is_null());
  CHECK(copy["nodeName"] == "body");
  CHECK(copy["transform"]["translation"] == json{-1.0, -0.5, 0.0});
  const json armCopy = api.get(s.path() + "/objects/5", s.token).json;
  CHECK(armCopy["parent"] == 4);
  CHECK(armCopy["nodeName"] == "arm");
  CHECK(armCopy["name"] == api.get(s.path() + "/objects/3", s.token).json["name"]);
  CHECK(armCopy["transform"]["translation"] == json{2.0, 0.0, 0.0});
  CHECK(armCopy["bounds"]["min"] == json{0.5, -1.0, 0.0});

  // In the frame: the originals' pixels unchanged, the copies as many pixels, in the same
  // columns, lower.
  const std::vector<uint32_t> after = rawIds(api, s, "instance-id");
  for (uint32_t id : {2u, 3u}) CHECK(columnOf(after, id) == columnOf(before, id));
  const auto [copyColumn, copyPixels] = columnOf(after, 4);
  const auto [armCopyColumn, armCopyPixels] = columnOf(after, 5);
  MESSAGE("body " << bodyPixels << " px at column " << bodyColumn << ", its copy " << copyPixels
                  << " px at " << copyColumn << "; arm " << armPixels << " at " << armColumn
                  << ", its copy " << armCopyPixels << " at " << armCopyColumn);
  CHECK(double(copyPixels) == doctest::Approx(double(bodyPixels)).epsilon(0.15));
  CHECK(double(armCopyPixels) == doctest::Approx(double(armPixels)).epsilon(0.15));
  CHECK(std::abs(copyColumn - bodyColumn) <= 1.0);
  CHECK(std::abs(armCopyColumn - armColumn) <= 1.0);
  auto meanRow = [&](const std::vector<uint32_t>& ids, uint32_t id) {
    double sum = 0.0;
    size_t n = 0;
    for (size_t p = 0; p < ids.size(); ++p) {
      if (ids[p] == id) sum += double(p / kWidth), ++n;
    }
    return n > 0 ? sum / double(n) : -1.0;
  };
  // 1.5 units at 6 units away, 50 degree field of view, 96 rows: 25.7 rows lower.
  CHECK(meanRow(after, 4) - meanRow(after, 2) == doctest::Approx(25.7).epsilon(0.1));

  // children false: the object alone, under its parent; no body: a copy as it is.
  Reply alone = api.post(s.path() + "/objects/2/duplicate", R"({"children": false, "parent": 4})", s.token);
  REQUIRE(alone.status == 201);
  CHECK(alone.json["ids"] == json{6});
  CHECK(api.get(s.path() + "/objects/6", s.token).json["parent"] == 4);
  Reply bare = api.post(s.path() + "/objects/3/duplicate", "", s.token);
  INFO(bare.body.substr(0, 300));
  REQUIRE(bare.status == 201);
  CHECK(bare.json["ids"] == json{7});
  CHECK(api.get(s.path() + "/objects/7", s.token).json["parent"] == 2);

  // Refusals name what is wrong, and change nothing.
  checkProblem(api.post(s.path() + "/objects/99/duplicate", "{}", s.token), 404, "not-found",
               "an unknown object");
  checkProblem(api.post(s.path() + "/objects/2/duplicate", R"({"parent": 99})", s.token), 400,
               "invalid-body", "an unknown parent", "/parent");
  checkProblem(api.post(s.path() + "/objects/2/duplicate", R"({"colour": 1})", s.token), 400,
               "invalid-body", "a member the schema lacks");
  checkProblem(api.post(s.path() + "/objects/2/duplicate",
                        R"({"transform": {"translation": [1, 0, 0], "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}})",
                        s.token),
               400, "invalid-body", "TRS with a matrix", "/transform");
  CHECK(api.get(s.path() + "/objects", s.token).json["total"] == 6);
  // Deleting the copy deletes its copied children; the originals stay.
  REQUIRE(api.del(s.path() + "/objects/4", s.token).status == 204);
  CHECK(api.get(s.path() + "/objects", s.token).json["total"] == 3);
  CHECK(api.get(s.path() + "/objects/5", s.token).status == 404);
  CHECK(api.get(s.path() + "/objects/3", s.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
}
