// Scenes of many objects against the real server (lavapipe, validation on): assets, objects, a
// move that changes only the moved object's pixels, parents, deletes and 409s, snapshots, and
// hostile object requests (service/scene_graph.h, api_objects.cpp).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "encode/png.h"
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

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

fs::path helmetGlb() {
  const char* env = std::getenv("MYRIAD_TEST_ASSETS_DIR");
  return fs::path(env != nullptr ? env : MYRIAD_TEST_ASSETS_DIR) / "DamagedHelmet" /
         "DamagedHelmet.glb";
}

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

// POST .../assets with a file; REQUIREs 201 and returns the asset.
json addAsset(ApiClient& api, const TestSession& s, const fs::path& file) {
  Reply r = api.post(s.path() + "/assets?filename=" + file.filename().string(), readFile(file),
                     s.token, "application/octet-stream");
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

json at(double x, double y, double z, double scale = 1.0) {
  return {{"translation", {x, y, z}}, {"scale", {scale, scale, scale}}};
}

// A frame of the session as decoded pixels: no antialiasing (an edge pass would reach one pixel
// past an object's silhouette), no markers.
myriad::encode::DecodedImage frame(ApiClient& api, const TestSession& s, int width = 192,
                                   int height = 108) {
  Reply r = api.get(s.path() + "/frame?format=png&width=" + std::to_string(width) +
                        "&height=" + std::to_string(height),
                    s.token);
  INFO(r.body.substr(0, 300));
  REQUIRE(r.status == 200);
  return myriad::encode::decodePng(
      std::span(reinterpret_cast<const uint8_t*>(r.body.data()), r.body.size()));
}

// The pixels where two frames differ.
std::vector<bool> differing(const myriad::encode::DecodedImage& a,
                            const myriad::encode::DecodedImage& b) {
  REQUIRE(a.rgba.size() == b.rgba.size());
  std::vector<bool> out(a.rgba.size() / 4);
  for (size_t p = 0; p < out.size(); ++p) {
    out[p] = !std::equal(a.rgba.begin() + p * 4, a.rgba.begin() + p * 4 + 4, b.rgba.begin() + p * 4);
  }
  return out;
}

size_t count(const std::vector<bool>& mask) { return size_t(std::count(mask.begin(), mask.end(), true)); }

// A session that shows only what objects cover: no sun shadow (a moved object's shadow falls on
// others), no local lights' markers, no antialiasing.
void plainSettings(ApiClient& api, const TestSession& s) {
  REQUIRE(api.patch(s.path() + "/settings",
                    R"({"markers": false, "antialias": "none", "shadows": {"sun": false}})", s.token)
              .status == 200);
}

}  // namespace

TEST_CASE("scene: three assets and 1,000 objects; a move changes only that object's pixels") {
  ServerProcess server({"--lights", "16"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  plainSettings(api, s);

  // The session starts as one asset (the built-in scene) and one root object.
  Reply assets = api.get(s.path() + "/assets", s.token);
  REQUIRE(assets.status == 200);
  REQUIRE(assets.json.at("assets").size() == 1);
  CHECK(assets.json["assets"][0]["source"] == "builtin:default");
  Reply objects = api.get(s.path() + "/objects", s.token);
  REQUIRE(objects.status == 200);
  CHECK(objects.json.at("total") == 1);
  CHECK(objects.json["objects"][0]["id"] == 1);
  CHECK(objects.json["objects"][0]["parent"].is_null());
  // Hide the built-in scene: what remains is ours.
  REQUIRE(api.patch(s.path() + "/objects/1", R"({"visible": false})", s.token).status == 200);

  const json spider = addAsset(api, s, kSpider);
  const json box = addAsset(api, s, kBox);
  CHECK(spider.at("id").get<std::string>().starts_with("a-"));
  CHECK(spider.at("bytes") == fs::file_size(kSpider));
  CHECK(spider.at("objects") == 0);
  // Content-addressed: the same bytes again are the same asset (200, not a second one).
  Reply again = api.post(s.path() + "/assets?filename=again.obj", readFile(kSpider), s.token,
                         "application/octet-stream");
  CHECK(again.status == 200);
  CHECK(again.json.at("id") == spider.at("id"));
  const bool haveHelmet = fs::exists(helmetGlb());
  json helmet;
  if (haveHelmet) {
    helmet = addAsset(api, s, helmetGlb());
  } else {
    MESSAGE("DamagedHelmet not found at ", helmetGlb().string(), ": two assets instead of three");
  }
  CHECK(api.get(s.path() + "/assets", s.token).json.at("assets").size() == (haveHelmet ? 4u : 3u));

  // 1,000 objects on a 40 x 25 grid in front of the camera, in one request, all three assets.
  json grid = json::array();
  for (int i = 0; i < 1000; ++i) {
    const double x = -6.0 + 0.3 * (i % 40), z = -6.0 + 0.45 * (i / 40);
    if (haveHelmet && i % 100 == 0) {
      grid.push_back({{"asset", helmet["id"]}, {"transform", at(x, 0.3, z, 0.15)}});
    } else if (i % 2 == 0) {
      grid.push_back({{"asset", box["id"]}, {"transform", at(x, 0.1, z, 0.2)}, {"semantic", 2}});
    } else {
      grid.push_back({{"asset", spider["id"]}, {"transform", at(x, 0.1, z, 0.002)}, {"semantic", 3}});
    }
  }
  const std::vector<uint32_t> ids = addObjects(api, s, grid);
  REQUIRE(ids.size() == 1000);
  CHECK(ids.front() == 2);
  CHECK(ids.back() == 1001);
  Reply page = api.get(s.path() + "/objects?offset=1&limit=3", s.token);
  REQUIRE(page.status == 200);
  CHECK(page.json.at("total") == 1001);
  CHECK(page.json.at("nextObjectId") == 1002);
  REQUIRE(page.json.at("objects").size() == 3);
  CHECK(page.json["objects"][0]["id"] == 2);

  // The camera looks at the grid's middle from above.
  REQUIRE(api.put(s.path() + "/camera",
                  R"({"eye": [0, 4, 6], "target": [0, 0, -1], "up": [0, 1, 0], "fovY": 50, "near": 0.1, "far": 50})",
                  s.token)
              .status == 200);
  const auto before = frame(api, s);

  // One box in view, hidden and shown: where it draws.
  const uint32_t moved = ids[20 * 40 + 20];  // a box (even index) near the middle
  const std::string movedPath = s.path() + "/objects/" + std::to_string(moved);
  REQUIRE(api.patch(movedPath, R"({"visible": false})", s.token).status == 200);
  const auto hidden = frame(api, s);
  const std::vector<bool> footprintBefore = differing(before, hidden);
  REQUIRE(count(footprintBefore) > 20);
  REQUIRE(api.patch(movedPath, R"({"visible": true})", s.token).status == 200);
  CHECK(differing(before, frame(api, s)) == std::vector<bool>(footprintBefore.size(), false));

  // The move: a transform PATCH writes only its instances. Only pixels it covered before or
  // covers now change; every other pixel is byte-identical.
  const json original = api.get(movedPath, s.token).json;
  json target = original["transform"];
  target["translation"][0] = target["translation"][0].get<double>() + 0.4;
  Reply patched = api.patch(movedPath, json{{"transform", target}}.dump(), s.token);
  REQUIRE(patched.status == 200);
  CHECK(patched.json["transform"]["translation"][0].get<double>() ==
        doctest::Approx(original["transform"]["translation"][0].get<double>() + 0.4));
  const auto after = frame(api, s);
  REQUIRE(api.patch(movedPath, R"({"visible": false})", s.token).status == 200);
  const std::vector<bool> footprintAfter = differing(after, frame(api, s));
  REQUIRE(api.patch(movedPath, R"({"visible": true})", s.token).status == 200);
  // Showing it again uploads the whole scene: the in-place move drew the same picture.
  const auto reuploaded = frame(api, s);
  CHECK(after.rgba == reuploaded.rgba);
  const std::vector<bool> changed = differing(before, after);
  size_t outside = 0;
  for (size_t p = 0; p < changed.size(); ++p) {
    if (changed[p] && !footprintBefore[p] && !footprintAfter[p]) ++outside;
  }
  CHECK(count(changed) > 0);
  CHECK(outside == 0);

  // Labels of the same view: the moved box's pixels are exactly where hiding it changed the
  // picture (no shadows, no antialiasing), and its 2D box is theirs.
  Reply labels = api.get(s.path() + "/labels?width=192&height=108", s.token);
  REQUIRE(labels.status == 200);
  const json* mine = nullptr;
  for (const json& l : labels.json.at("objects")) {
    if (l.at("id") == moved) mine = &l;
  }
  REQUIRE(mine != nullptr);
  CHECK((*mine)["pixels"] == count(footprintAfter));
  CHECK((*mine)["semantic"] == 2);
  uint32_t x0 = 192, y0 = 108, x1 = 0, y1 = 0;
  for (size_t p = 0; p < footprintAfter.size(); ++p) {
    if (!footprintAfter[p]) continue;
    const uint32_t x = uint32_t(p % 192), y = uint32_t(p / 192);
    x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
  }
  CHECK((*mine)["box"] == json::array({x0, y0, x1, y1}));
  CHECK((*mine)["bounds"] == api.get(movedPath, s.token).json["bounds"]);
  // The raw instance-id frame says the same, pixel for pixel.
  Reply idFrame = api.get(s.path() + "/frame?target=instance-id&format=raw&width=192&height=108", s.token);
  REQUIRE(idFrame.status == 200);
  CHECK(idFrame.header("X-Myriad-Dtype") == "uint32");
  REQUIRE(idFrame.body.size() == footprintAfter.size() * 4);
  size_t agree = 0;
  for (size_t p = 0; p < footprintAfter.size(); ++p) {
    uint32_t id = 0;
    std::memcpy(&id, idFrame.body.data() + p * 4, 4);
    agree += (id == moved) == bool(footprintAfter[p]) ? 1 : 0;
  }
  CHECK(agree == footprintAfter.size());

  // Parents: a child follows its parent's move; hiding the parent hides it.
  const std::vector<uint32_t> family = addObjects(
      api, s,
      json::array({{{"asset", box["id"]}, {"name", "parent"}, {"transform", at(0, 2, -1, 0.3)}},
                   {{"asset", box["id"]}, {"name", "child"}, {"parent", 1002},
                    {"transform", at(2, 0, 0)}}}));
  REQUIRE(family == std::vector<uint32_t>{1002, 1003});
  const std::string parentPath = s.path() + "/objects/1002";
  const std::string childPath = s.path() + "/objects/1003";
  const json childBefore = api.get(childPath, s.token).json;
  CHECK(childBefore.at("parent") == 1002);
  REQUIRE(api.patch(parentPath, json{{"transform", at(1, 2, -1, 0.3)}}.dump(), s.token).status == 200);
  const json childAfter = api.get(childPath, s.token).json;
  CHECK(childAfter["bounds"]["min"][0].get<double>() ==
        doctest::Approx(childBefore["bounds"]["min"][0].get<double>() + 1.0).epsilon(1e-4));
  CHECK(childAfter["bounds"]["min"][1].get<double>() ==
        doctest::Approx(childBefore["bounds"]["min"][1].get<double>()).epsilon(1e-4));
  REQUIRE(api.patch(parentPath, R"({"visible": false})", s.token).status == 200);
  CHECK(api.get(childPath, s.token).json.at("instances") == 0);
  REQUIRE(api.patch(parentPath, R"({"visible": true})", s.token).status == 200);
  CHECK(api.get(childPath, s.token).json.at("instances") == 1);

  // A snapshot restores the same frame, byte for byte, onto a session that has the uploads.
  // (One light added: a snapshot lists the lights then. A built-in session's generated lights
  // restore through the generator around the model, not the built-in scene's own layout.)
  REQUIRE(api.post(s.path() + "/lights",
                   R"({"lights": [{"position": [0, 1, -1], "radius": 3, "color": [1, 0.8, 0.6], "intensity": 3, "falloff": 1}]})",
                   s.token)
              .status == 201);
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  REQUIRE(snapshot.json.contains("scene"));
  CHECK(snapshot.json["scene"]["objects"].size() == 1003);
  TestSession copy = createSession(api);
  addAsset(api, copy, kBox);  // uploaded in another order: the snapshot's order wins
  addAsset(api, copy, kSpider);
  if (haveHelmet) addAsset(api, copy, helmetGlb());
  Reply restored = api.put(copy.path() + "/snapshot", snapshot.body, copy.token);
  INFO(restored.body.substr(0, 400));
  REQUIRE(restored.status == 200);
  CHECK(api.get(copy.path() + "/snapshot", copy.token).json == snapshot.json);
  CHECK(frame(api, copy).rgba == frame(api, s).rgba);
  // Without the uploads, the snapshot names the asset it lacks.
  checkProblem(api.post("/v1/sessions", json{{"snapshot", snapshot.json}}.dump()), 400,
               "invalid-body", "missing upload", "/snapshot/scene/assets/1/id");

  // Deletes: an asset in use is 409 naming an object; a parent's delete takes its children.
  checkProblem(api.del(s.path() + "/assets/" + box["id"].get<std::string>(), s.token), 409,
               "conflict", "asset in use");
  REQUIRE(api.del(parentPath, s.token).status == 204);
  checkProblem(api.get(childPath, s.token), 404, "not-found", "child deleted with its parent");
  CHECK(api.get(s.path() + "/objects?limit=0", s.token).json.at("total") == 1001);
  // An unused asset goes; later assets' materials move down.
  const json lone =
      addAsset(api, s, "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf");
  CHECK(lone.at("objects") == 0);
  REQUIRE(api.del(s.path() + "/assets/" + lone["id"].get<std::string>(), s.token).status == 204);
  checkProblem(api.get(s.path() + "/assets/" + lone["id"].get<std::string>(), s.token), 404,
               "not-found", "deleted asset");
  CHECK(myriad::test::validationMessages(api) == 0);
  std::optional<myriad::test::ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  CHECK(status->cleanExit());
}

TEST_CASE("scene: hostile object requests are 4xx naming the member; the server keeps serving") {
  ServerProcess server({"--lights", "4", "--max-objects", "50"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  TestSession other = createSession(api);
  const std::string builtin = api.get(s.path() + "/assets", s.token).json["assets"][0]["id"];
  const std::string objects = s.path() + "/objects";
  auto add = [&](const json& object) {
    return api.post(objects, json{{"objects", json::array({object})}}.dump(), s.token);
  };
  // Zero scale, a zero quaternion, a singular or projective matrix, numbers past the schema.
  checkProblem(add({{"asset", builtin}, {"transform", {{"scale", {0, 1, 1}}}}}), 400,
               "invalid-body", "zero scale", "/objects/0/transform");
  checkProblem(add({{"asset", builtin}, {"transform", {{"rotation", {0, 0, 0, 0}}}}}), 400,
               "invalid-body", "zero quaternion", "/objects/0/transform/rotation");
  checkProblem(add({{"asset", builtin},
                    {"transform", {{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1}}}}}),
               400, "invalid-body", "projective matrix", "/objects/0/transform");
  checkProblem(add({{"asset", builtin},
                    {"transform", {{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}},
                                   {"scale", {1, 1, 1}}}}}),
               400, "invalid-body", "matrix and TRS", "/objects/0/transform");
  checkProblem(add({{"asset", builtin}, {"transform", {{"translation", {1e300, 0, 0}}}}}), 400,
               "invalid-body", "huge translation", "/objects/0/transform/translation/0");
  // A missing asset, parent or material.
  checkProblem(add({{"asset", "a-0000000000000000"}}), 400, "invalid-body", "missing asset",
               "/objects/0/asset");
  checkProblem(add({{"asset", builtin}, {"parent", 77}}), 400, "invalid-body", "missing parent",
               "/objects/0/parent");
  checkProblem(add({{"asset", builtin}, {"material", 100000}}), 400, "invalid-body",
               "missing material", "/objects/0/material");
  // A cycle of parents: 2 under 1, then 1 under 2.
  REQUIRE(add({{"asset", builtin}, {"parent", 1}}).status == 201);
  checkProblem(api.patch(objects + "/1", R"({"parent": 2})", s.token), 400, "invalid-body",
               "cycle", "/parent");
  checkProblem(api.patch(objects + "/1", R"({"parent": 1})", s.token), 400, "invalid-body",
               "own parent", "/parent");
  // Too many: 10,001 in one request is the schema's 400; past --max-objects, 413 naming it.
  json many = json::array();
  for (int i = 0; i < 10001; ++i) many.push_back({{"asset", builtin}});
  checkProblem(api.post(objects, json{{"objects", many}}.dump(), s.token), 400, "invalid-body",
               "10,001 objects", "/objects");
  many.erase(many.begin() + 49, many.end());
  checkProblem(api.post(objects, json{{"objects", many}}.dump(), s.token), 413, "limit-exceeded",
               "past --max-objects", std::nullopt, "maxObjectsPerSession");
  // Ids that are not objects, and another session's token.
  checkProblem(api.get(objects + "/abc", s.token), 404, "not-found", "not an id");
  checkProblem(api.get(objects + "/99999999999", s.token), 404, "not-found", "past uint32");
  checkProblem(api.get(objects + "/1", other.token), 403, "forbidden", "other session's token");
  checkProblem(api.del(s.path() + "/assets/a-0000000000000000", s.token), 404, "not-found",
               "missing asset");
  // Nothing changed, and both sessions still render.
  CHECK(api.get(objects, s.token).json.at("total") == 2);
  CHECK(api.get(s.path() + "/frame?width=64&height=36", s.token).status == 200);
  CHECK(api.get(other.path() + "/frame?width=64&height=36", other.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
  std::optional<myriad::test::ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  CHECK(status->cleanExit());
}

namespace {

// A raw frame's float32 values.
std::vector<float> rawFloats(const Reply& r) {
  std::vector<float> out(r.body.size() / 4);
  std::memcpy(out.data(), r.body.data(), out.size() * 4);
  return out;
}

}  // namespace

TEST_CASE("scene: every frame carries its camera; world positions project onto their pixels") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  // An off-axis, tilted view with a non-default field of view and a wide frame.
  REQUIRE(api.put(s.path() + "/camera",
                  R"({"eye": [3.5, 2.5, 4.0], "target": [-0.5, 0.3, -1.0], "up": [0.1, 1, 0], "fovY": 40, "near": 0.1, "far": 40})",
                  s.token)
              .status == 200);
  const int width = 160, height = 90;
  const std::string size = "&width=" + std::to_string(width) + "&height=" + std::to_string(height);
  Reply png = api.get(s.path() + "/frame?format=png" + size, s.token);
  REQUIRE(png.status == 200);
  const json k = json::parse(png.header("X-Myriad-Intrinsics"));
  const json pose = json::parse(png.header("X-Myriad-Pose"))["worldFromCamera"];
  CHECK(k["width"] == width);
  CHECK(k["height"] == height);
  CHECK(k["near"].get<double>() == doctest::Approx(0.1));
  CHECK(k["far"].get<double>() == doctest::Approx(40));
  CHECK(k["cx"].get<double>() == doctest::Approx(80));
  CHECK(k["fy"].get<double>() == doctest::Approx(45.0 / std::tan(20.0 * 3.14159265358979 / 180.0)));
  // The pose's translation is the eye; its third column (camera +z) looks at the target.
  CHECK(pose[0][3].get<double>() == doctest::Approx(3.5));
  CHECK(pose[2][3].get<double>() == doctest::Approx(4.0));

  Reply position = api.get(s.path() + "/frame?format=raw&target=position" + size, s.token);
  Reply z = api.get(s.path() + "/frame?format=raw&target=depth" + size, s.token);
  Reply distance = api.get(s.path() + "/frame?format=raw&target=depth&depth=distance" + size, s.token);
  REQUIRE(position.status == 200);
  REQUIRE(z.status == 200);
  REQUIRE(distance.status == 200);
  CHECK(z.header("X-Myriad-Depth") == "z");
  CHECK(distance.header("X-Myriad-Depth") == "distance");
  CHECK(json::parse(position.header("X-Myriad-Intrinsics")) == k);
  const std::vector<float> p = rawFloats(position), zs = rawFloats(z), ds = rawFloats(distance);
  REQUIRE(p.size() == size_t(width * height * 3));
  REQUIRE(zs.size() == size_t(width * height));
  REQUIRE(ds.size() == zs.size());
  double R[3][3], t[3];
  for (int r = 0; r < 3; ++r) {
    t[r] = pose[r][3].get<double>();
    for (int c = 0; c < 3; ++c) R[r][c] = pose[r][c].get<double>();
  }
  const double fx = k["fx"], fy = k["fy"], cx = k["cx"], cy = k["cy"];
  size_t surfaces = 0, offPixel = 0, offZ = 0, offDistance = 0;
  double worstPixel = 0.0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = size_t(y) * width + x;
      REQUIRE(std::isfinite(zs[i]));
      REQUIRE(std::isfinite(ds[i]));
      if (zs[i] >= 40.0f) {
        CHECK(ds[i] == zs[i]);  // no surface: far in both conventions
        continue;
      }
      ++surfaces;
      // Camera space = R^T (P - t) (the pose is a rotation and a translation).
      const double d[3] = {p[i * 3] - t[0], p[i * 3 + 1] - t[1], p[i * 3 + 2] - t[2]};
      double c[3];
      for (int a = 0; a < 3; ++a) c[a] = R[0][a] * d[0] + R[1][a] * d[1] + R[2][a] * d[2];
      const double u = fx * c[0] / c[2] + cx, v = fy * c[1] / c[2] + cy;
      const double miss = std::max(std::abs(u - (x + 0.5)), std::abs(v - (y + 0.5)));
      worstPixel = std::max(worstPixel, miss);
      if (miss > 0.05) ++offPixel;
      if (std::abs(c[2] - zs[i]) > 1e-4 * zs[i]) ++offZ;
      const double length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      if (std::abs(length - ds[i]) > 1e-4 * length) ++offDistance;
    }
  }
  // The same positions and normals in camera space (?space=camera): R^T (P - t) and R^T n, and
  // the camera-space z is the depth.
  Reply cameraPosition = api.get(s.path() + "/frame?format=raw&target=position&space=camera" + size, s.token);
  Reply worldNormal = api.get(s.path() + "/frame?format=raw&target=normal" + size, s.token);
  Reply cameraNormal = api.get(s.path() + "/frame?format=raw&target=normal&space=camera" + size, s.token);
  REQUIRE(cameraPosition.status == 200);
  REQUIRE(cameraNormal.status == 200);
  CHECK(cameraPosition.header("X-Myriad-Space") == "camera");
  CHECK(worldNormal.header("X-Myriad-Space") == "world");
  const std::vector<float> cp = rawFloats(cameraPosition), wn = rawFloats(worldNormal),
                           cn = rawFloats(cameraNormal);
  REQUIRE(cp.size() == p.size());
  REQUIRE(cn.size() == wn.size());
  size_t offCamera = 0, offNormal = 0;
  for (size_t i = 0; i < zs.size(); ++i) {
    if (zs[i] >= 40.0f) continue;
    const double d[3] = {p[i * 3] - t[0], p[i * 3 + 1] - t[1], p[i * 3 + 2] - t[2]};
    for (int a = 0; a < 3; ++a) {
      const double c = R[0][a] * d[0] + R[1][a] * d[1] + R[2][a] * d[2];
      const double n = R[0][a] * wn[i * 3] + R[1][a] * wn[i * 3 + 1] + R[2][a] * wn[i * 3 + 2];
      if (std::abs(cp[i * 3 + a] - c) > 1e-4 * (1.0 + std::abs(c))) ++offCamera;
      if (std::abs(cn[i * 3 + a] - n) > 1e-5) ++offNormal;
    }
    if (std::abs(cp[i * 3 + 2] - zs[i]) > 1e-4 * zs[i]) ++offCamera;
  }
  CHECK(offCamera == 0);
  CHECK(offNormal == 0);
  checkProblem(api.get(s.path() + "/frame?format=raw&target=depth&space=camera", s.token), 400,
               "invalid-parameter", "space with depth", std::nullopt, std::nullopt, "space");
  INFO("worst reprojection error: ", worstPixel, " px");
  CHECK(surfaces > size_t(width * height / 2));
  CHECK(offPixel == 0);
  CHECK(offZ == 0);
  CHECK(offDistance == 0);
  // depth= is for raw depth only.
  checkProblem(api.get(s.path() + "/frame?format=png&target=depth&depth=distance", s.token), 400,
               "invalid-parameter", "depth with png", std::nullopt, std::nullopt, "depth");
  checkProblem(api.get(s.path() + "/frame?format=raw&target=depth&depth=metres", s.token), 400,
               "invalid-parameter", "unknown convention", std::nullopt, std::nullopt, "depth");
  CHECK(myriad::test::validationMessages(api) == 0);
  std::optional<myriad::test::ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  CHECK(status->cleanExit());
}

// A label's total pixels: what the object covers with nothing in front. Measured against the GPU
// itself: the partly hidden box's total equals (within pixels whose centres lie on an edge, where
// the CPU's float rasteriser and the GPU's fixed point may choose differently) its visible pixels
// once the box in front is hidden.
TEST_CASE("labels: total pixels are what an object covers alone; visible never exceeds them") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  plainSettings(api, s);
  REQUIRE(api.patch(s.path() + "/objects/1", R"({"visible": false})", s.token).status == 200);
  const json box = addAsset(api, s, kBox);
  // B behind, A in front and to the left: A hides part of B.
  const std::vector<uint32_t> ids = addObjects(
      api, s, json::array({{{"asset", box["id"]}, {"transform", at(0.0, 0.0, -1.0)}},
                           {{"asset", box["id"]}, {"transform", at(-0.6, 0.0, 0.5, 0.8)}}}));
  REQUIRE(ids.size() == 2);
  const uint32_t behind = ids[0], front = ids[1];
  REQUIRE(api.put(s.path() + "/camera",
                  R"({"eye": [0, 0.8, 4], "target": [0, 0, -0.5], "up": [0, 1, 0], "fovY": 50, "near": 0.1, "far": 50})",
                  s.token)
              .status == 200);
  auto labelsOf = [&] {
    Reply r = api.get(s.path() + "/labels?width=320&height=240", s.token);
    INFO(r.body.substr(0, 400));
    REQUIRE(r.status == 200);
    std::map<uint32_t, json> byId;
    for (const json& l : r.json.at("objects")) byId[l.at("id").get<uint32_t>()] = l;
    return byId;
  };
  auto both = labelsOf();
  REQUIRE(both.contains(behind));
  REQUIRE(both.contains(front));
  const uint64_t behindVisible = both[behind]["pixels"], behindTotal = both[behind]["totalPixels"];
  const uint64_t frontVisible = both[front]["pixels"], frontTotal = both[front]["totalPixels"];
  MESSAGE("behind: ", behindVisible, " of ", behindTotal, "; front: ", frontVisible, " of ", frontTotal);
  CHECK(behindVisible + 500 < behindTotal);  // A hides a good part of B
  // Edge pixels: about one per pixel of outline, at most.
  const auto close = [](uint64_t gpu, uint64_t cpu) {
    const double outline = 4.0 * std::sqrt(double(gpu));
    return std::abs(double(gpu) - double(cpu)) <= 0.5 * outline;
  };
  CHECK(close(frontVisible, frontTotal));  // nothing is in front of A
  REQUIRE(api.patch(s.path() + "/objects/" + std::to_string(front), R"({"visible": false})", s.token)
              .status == 200);
  auto alone = labelsOf();
  REQUIRE(alone.contains(behind));
  CHECK_FALSE(alone.contains(front));
  const uint64_t behindAlone = alone[behind]["pixels"];
  MESSAGE("behind alone: ", behindAlone, " (CPU total ", alone[behind]["totalPixels"].get<uint64_t>(), ")");
  CHECK(close(behindAlone, behindTotal));
  CHECK(alone[behind]["totalPixels"] == behindTotal);  // its own coverage did not change
  for (const auto& [id, l] : both) CHECK(l["pixels"].get<uint64_t>() <= l["totalPixels"].get<uint64_t>());
}
