// The session API (protocol/CONTRACT.md) against the real myriad-server on loopback, validation
// layers on: every session, model, camera, settings, material and light route with its status and
// body; isolation between sessions; limits (413, 429); schema rejections with their pointers;
// every Assimp test file uploaded; the model library; idle expiry; GPU memory freed on DELETE.
#include <doctest/doctest.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "gltf_builder.h"
#include "server_process.h"
#include "zip_builder.h"

using myriad::test::ApiClient;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using nlohmann::json;

namespace {

namespace fs = std::filesystem;

const fs::path kAssimpModels = "/usr/share/assimp/models";
constexpr const char* kBox = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A temporary --models directory with one model at the top and one in a subfolder.
struct ModelDir {
  fs::path root;
  ModelDir() {
    std::string pattern = "/tmp/myriad-api-models-XXXXXX";
    REQUIRE(mkdtemp(pattern.data()) != nullptr);
    root = pattern;
    fs::create_directories(root / "sub");
    fs::copy_file(kBox, root / "box.glb");
    fs::copy_file(kBox, root / "sub" / "box2.glb");
  }
  ~ModelDir() { fs::remove_all(root); }
};

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

void checkStopsCleanly(ServerProcess& server) {
  std::optional<myriad::test::ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  INFO(server.stderrText().substr(0, 4000));
  CHECK(status->cleanExit());
}

bool near(double a, double b, double tolerance = 1e-5) { return std::abs(a - b) <= tolerance; }

bool vecNear(const json& v, std::initializer_list<double> expected, double tolerance = 1e-5) {
  if (!v.is_array() || v.size() != expected.size()) return false;
  size_t i = 0;
  for (double e : expected) {
    if (!near(v[i++].get<double>(), e, tolerance)) return false;
  }
  return true;
}

json lightJson(double x, double radius = 1.5) {
  return {{"position", {x, 1.0, 0.0}},
          {"radius", radius},
          {"color", {1.0, 0.5, 0.25}},
          {"intensity", 2.0},
          {"falloff", 1.0}};
}

uint64_t gpuMemory(ApiClient& api) {
  Reply info = api.get("/v1/info");
  REQUIRE(info.status == 200);
  return info.json.at("gpuMemoryBytes").get<uint64_t>();
}

}  // namespace

TEST_CASE("api: a session's whole life through every route it owns") {
  ModelDir models;
  ServerProcess server({"--lights", "8", "--models", models.root.string()});
  requireListening(server);
  ApiClient api(server);

  // GET /v1/info lists every limit.
  Reply info = api.get("/v1/info");
  REQUIRE(info.status == 200);
  const json& limits = info.json.at("limits");
  for (const char* name : {"maxResolution", "maxQueuedFrames", "maxSessions", "maxLightsPerSession",
                           "maxUploadBytes", "maxBodyBytes", "maxStreams", "maxRequestsInFlight",
                           "sessionIdleSeconds"}) {
    CHECK_MESSAGE(limits.contains(name), name);
  }
  CHECK(limits.at("maxLightsPerSession") == 1000000);
  CHECK(limits.at("maxUploadBytes") == 64 << 20);
  CHECK(limits.at("maxBodyBytes") == 1 << 20);
  CHECK(limits.at("sessionIdleSeconds") == 600);
  CHECK(info.json.at("apiKeyRequired") == false);

  // GET /v1/models: the library, recursively, names relative to it.
  Reply modelList = api.get("/v1/models");
  REQUIRE(modelList.status == 200);
  const uint64_t boxBytes = fs::file_size(kBox);
  CHECK(modelList.json == json{{"models",
                                {{{"name", "box.glb"}, {"bytes", boxBytes}},
                                 {{"name", "sub/box2.glb"}, {"bytes", boxBytes}}}}});

  // POST /v1/sessions.
  Reply created = api.post("/v1/sessions", "");
  REQUIRE(created.status == 201);
  const std::string id = created.json.at("id");
  const std::string token = created.json.at("token");
  CHECK(std::regex_match(id, std::regex("s-[0-9a-f]{16}")));
  CHECK(std::regex_match(token, std::regex("[0-9a-f]{64}")));
  CHECK(created.json.at("expiresInSeconds") == 600);
  CHECK(created.header("Location") == "/v1/sessions/" + id);
  const json& state = created.json.at("session");
  CHECK(state.at("id") == id);
  CHECK(state.at("model").at("source") == "builtin:default");
  CHECK(state.at("model").at("meshes").get<int>() > 0);
  CHECK(state.at("model").at("materials").get<int>() > 0);
  CHECK(state.at("lights").at("count") == 8);
  CHECK(state.at("settings").at("technique") == "clustered");
  const std::string path = "/v1/sessions/" + id;

  // GET /v1/sessions/{id}.
  Reply got = api.get(path, token);
  REQUIRE(got.status == 200);
  CHECK(got.json.at("model") == state.at("model"));
  CHECK(got.json.at("camera") == state.at("camera"));

  // Camera: GET, PUT (whole), PATCH (subset), POST frame.
  Reply camera = api.get(path + "/camera", token);
  REQUIRE(camera.status == 200);
  CHECK(camera.json == state.at("camera"));
  const json newCamera = {{"eye", {0, 3, 9}}, {"target", {0, 1, 0}}, {"up", {0, 1, 0}},
                          {"fovY", 40},       {"near", 0.1},         {"far", 100}};
  Reply put = api.put(path + "/camera", newCamera.dump(), token);
  REQUIRE(put.status == 200);
  CHECK(put.json == newCamera);
  Reply patched = api.patch(path + "/camera", R"({"fovY": 70, "eye": [1, 2, 3]})", token);
  REQUIRE(patched.status == 200);
  CHECK(patched.json.at("fovY") == 70);
  CHECK(patched.json.at("eye") == json{1, 2, 3});
  CHECK(patched.json.at("target") == json{0, 1, 0});
  CHECK(api.get(path + "/camera", token).json == patched.json);
  Reply framed = api.post(path + "/camera/frame", "", token);
  REQUIRE(framed.status == 200);
  CHECK(framed.json.at("fovY") == 70);  // kept
  CHECK(framed.json.at("eye") != json{1, 2, 3});
  {
    // The framed camera looks at the model's centre from the direction it looked from before.
    const json& bounds = state.at("model").at("bounds");
    for (int axis = 0; axis < 3; ++axis) {
      double centre = 0.5 * (bounds["min"][axis].get<double>() + bounds["max"][axis].get<double>());
      CHECK(near(framed.json["target"][axis].get<double>(), centre, 1e-3));
    }
  }

  // Settings: GET, PATCH (sun members individually, direction normalized).
  Reply settings = api.get(path + "/settings", token);
  REQUIRE(settings.status == 200);
  CHECK(settings.json == state.at("settings"));
  const json sunColor = settings.json.at("sun").at("color");
  Reply newSettings = api.patch(
      path + "/settings",
      R"({"sun": {"direction": [0, -2, 0], "intensity": 3}, "exposure": 1.5, "technique": "tiled",
          "markers": false, "animate": true, "ambient": [0.1, 0.2, 0.3], "background": [0, 0, 0.5],
          "antialias": "none"})",
      token);
  REQUIRE(newSettings.status == 200);
  CHECK(settings.json["antialias"] == "fxaa");  // a new session's default
  CHECK(newSettings.json["antialias"] == "none");
  CHECK(vecNear(newSettings.json["sun"]["direction"], {0, -1, 0}));
  CHECK(newSettings.json["sun"]["intensity"] == 3);
  CHECK(newSettings.json["sun"]["color"] == sunColor);  // untouched member kept
  CHECK(newSettings.json["exposure"] == 1.5);
  CHECK(newSettings.json["technique"] == "tiled");
  CHECK(newSettings.json["markers"] == false);
  CHECK(newSettings.json["animate"] == true);
  CHECK(newSettings.json["ambient"] == json{0.1, 0.2, 0.3});
  CHECK(newSettings.json["background"] == json{0, 0, 0.5});
  CHECK(api.get(path + "/settings", token).json == newSettings.json);

  // Materials: GET, PATCH one.
  Reply materials = api.get(path + "/materials", token);
  REQUIRE(materials.status == 200);
  const json& list = materials.json.at("materials");
  REQUIRE(list.size() == state.at("model").at("materials").get<size_t>());
  for (size_t i = 0; i < list.size(); ++i) CHECK(list[i].at("id") == i);
  Reply material =
      api.patch(path + "/materials/1", R"({"baseColor": [0.25, 0.5, 1], "metallic": 1})", token);
  REQUIRE(material.status == 200);
  CHECK(material.json.at("id") == 1);
  CHECK(material.json.at("name") == list[1].at("name"));
  CHECK(material.json.at("baseColor") == json{0.25, 0.5, 1});
  CHECK(material.json.at("metallic") == 1);
  CHECK(material.json.at("roughness") == list[1].at("roughness"));
  CHECK(api.get(path + "/materials", token).json["materials"][1] == material.json);
  checkProblem(api.patch(path + "/materials/" + std::to_string(list.size()), "{}", token), 404,
               "not-found", "PATCH a material past the last");
  checkProblem(api.patch(path + "/materials/x", "{}", token), 404, "not-found",
               "PATCH material x");

  // Lights: page, add, get, patch, delete (the last light moves into the hole), clear, generate.
  Reply page = api.get(path + "/lights", token);
  REQUIRE(page.status == 200);
  CHECK(page.json.at("total") == 8);
  CHECK(page.json.at("offset") == 0);
  REQUIRE(page.json.at("lights").size() == 8);
  std::set<uint64_t> ids;
  for (const json& light : page.json["lights"]) ids.insert(light.at("id").get<uint64_t>());
  CHECK(ids.size() == 8);
  Reply page2 = api.get(path + "/lights?offset=6&limit=5", token);
  REQUIRE(page2.status == 200);
  CHECK(page2.json.at("offset") == 6);
  REQUIRE(page2.json.at("lights").size() == 2);
  CHECK(page2.json["lights"][0] == page.json["lights"][6]);

  Reply added = api.post(path + "/lights",
                         json{{"lights", {lightJson(1.0), lightJson(2.0), lightJson(3.0)}}}.dump(),
                         token);
  REQUIRE(added.status == 201);
  CHECK(added.json.at("total") == 11);
  REQUIRE(added.json.at("ids").size() == 3);
  std::vector<uint64_t> newIds = added.json.at("ids").get<std::vector<uint64_t>>();
  for (uint64_t newId : newIds) CHECK(!ids.contains(newId));
  CHECK(newIds[1] == newIds[0] + 1);
  CHECK(newIds[2] == newIds[1] + 1);

  const std::string first = path + "/lights/" + std::to_string(newIds[0]);
  Reply light = api.get(first, token);
  REQUIRE(light.status == 200);
  json expected = lightJson(1.0);
  expected["id"] = newIds[0];
  // What was left out: a point light with the window falloff, glTF's default cone (pi/4 as a
  // float, written as its shortest decimal) and no shadow map asked for.
  expected["type"] = "point";
  expected["attenuation"] = "window";
  expected["direction"] = {0, -1, 0};
  expected["innerConeAngle"] = 0;
  expected["outerConeAngle"] = 0.7853982;
  expected["castsShadows"] = false;
  CHECK(light.json == expected);
  Reply lightPatched = api.patch(first, R"({"radius": 4, "color": [0, 1, 0]})", token);
  REQUIRE(lightPatched.status == 200);
  expected["radius"] = 4;
  expected["color"] = {0, 1, 0};
  CHECK(lightPatched.json == expected);
  CHECK(api.get(first, token).json == expected);

  // Delete the first added light: the last one (id newIds[2]) takes its place in the list.
  Reply deleted = api.del(first, token);
  CHECK(deleted.status == 204);
  CHECK(deleted.body.empty());
  checkProblem(api.get(first, token), 404, "not-found", "GET a deleted light");
  checkProblem(api.del(first, token), 404, "not-found", "DELETE a deleted light");
  Reply afterDelete = api.get(path + "/lights?offset=8&limit=10", token);
  REQUIRE(afterDelete.status == 200);
  CHECK(afterDelete.json.at("total") == 10);
  REQUIRE(afterDelete.json.at("lights").size() == 2);
  CHECK(afterDelete.json["lights"][0]["id"] == newIds[2]);
  CHECK(afterDelete.json["lights"][1]["id"] == newIds[1]);
  // Ids are never reused, even after a delete.
  Reply addedAgain = api.post(path + "/lights", json{{"lights", {lightJson(4.0)}}}.dump(), token);
  REQUIRE(addedAgain.status == 201);
  CHECK(addedAgain.json["ids"][0] == newIds[2] + 1);

  Reply cleared = api.del(path + "/lights", token);
  CHECK(cleared.status == 204);
  CHECK(api.get(path + "/lights", token).json == json{{"total", 0}, {"offset", 0}, {"lights", json::array()}});

  Reply generated = api.post(path + "/lights/generate", R"({"count": 500, "seed": 7})", token);
  REQUIRE(generated.status == 200);
  CHECK(generated.json == json{{"total", 500}});
  Reply firstGenerated = api.get(path + "/lights?limit=3", token);
  Reply appended = api.post(
      path + "/lights/generate",
      R"({"count": 20, "seed": 8, "replace": false, "bounds": {"min": [-1, 0, -1], "max": [1, 2, 1]},
          "radius": [0.5, 0.75], "intensity": [1, 2], "falloff": 3})",
      token);
  REQUIRE(appended.status == 200);
  CHECK(appended.json == json{{"total", 520}});
  Reply tail = api.get(path + "/lights?offset=500&limit=1000", token);
  REQUIRE(tail.json.at("lights").size() == 20);
  for (const json& l : tail.json["lights"]) {
    for (int axis = 0; axis < 3; ++axis) {
      double p = l["position"][axis].get<double>();
      CHECK(p >= (axis == 1 ? 0.0 : -1.0) - 1e-6);
      CHECK(p <= (axis == 1 ? 2.0 : 1.0) + 1e-6);
    }
    CHECK(l["radius"].get<double>() >= 0.5 - 1e-6);
    CHECK(l["radius"].get<double>() <= 0.75 + 1e-6);
    CHECK(l["falloff"] == 3);
  }
  // The same seed gives the same lights.
  Reply regenerated = api.post(path + "/lights/generate", R"({"count": 500, "seed": 7})", token);
  REQUIRE(regenerated.status == 200);
  Reply again = api.get(path + "/lights?limit=3", token);
  CHECK(again.json["total"] == 500);
  for (int i = 0; i < 3; ++i) {
    json a = again.json["lights"][i], b = firstGenerated.json["lights"][i];
    CHECK(a["id"] != b["id"]);  // new lights, new ids
    a.erase("id");
    b.erase("id");
    CHECK(a == b);
  }

  // PUT model: library, builtin, upload; the generated lights' count kept (they are fitted to
  // each model) unless ?lights=model.
  Reply library = api.put(path + "/model", R"({"source": "library:sub/box2.glb"})", token);
  REQUIRE(library.status == 200);
  CHECK(library.json.at("model").at("source") == "library:sub/box2.glb");
  CHECK(library.json.at("lights").at("count") == 500);
  CHECK(library.json.at("model").at("materials") == 1);
  Reply boxMaterials = api.get(path + "/materials", token);
  REQUIRE(boxMaterials.json.at("materials").size() == 1);
  // The camera was reset to frame the new model.
  const json& boxBounds = library.json.at("model").at("bounds");
  for (int axis = 0; axis < 3; ++axis) {
    double centre =
        0.5 * (boxBounds["min"][axis].get<double>() + boxBounds["max"][axis].get<double>());
    CHECK(near(library.json["camera"]["target"][axis].get<double>(), centre, 1e-3));
  }
  Reply upload = api.put(path + "/model?filename=box.glb&lights=model", readFile(kBox), token,
                         "application/octet-stream");
  REQUIRE(upload.status == 200);
  CHECK(upload.json.at("model").at("source") == "upload:box.glb");
  CHECK(upload.json.at("lights").at("count") == 0);  // the box has no punctual lights
  Reply builtin = api.put(path + "/model", R"({"source": "builtin:default"})", token);
  REQUIRE(builtin.status == 200);
  CHECK(builtin.json.at("model") == state.at("model"));

  // DELETE: 204, then the session is gone.
  Reply gone = api.del(path, token);
  CHECK(gone.status == 204);
  checkProblem(api.get(path, token), 404, "not-found", "GET a deleted session");
  checkProblem(api.get(path + "/lights", token), 404, "not-found", "GET lights of a deleted session");
  checkProblem(api.del(path, token), 404, "not-found", "DELETE a deleted session");

  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

namespace {

// One HTTP/1.1 exchange over a plain socket, for requests httplib's client will not send (it
// always adds Content-Length). Returns what the server wrote before closing (3 s at most).
std::string exchangeRaw(int port, const std::string& request) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  REQUIRE(fd >= 0);
  timeval timeout{3, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
  REQUIRE(send(fd, request.data(), request.size(), 0) == static_cast<ssize_t>(request.size()));
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = recv(fd, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, size_t(n));
  close(fd);
  return answer;
}

}  // namespace

TEST_CASE("api: a POST with neither Content-Length nor Transfer-Encoding has an empty body") {
  // RFC 9112 section 6.3; `curl -X POST .../v1/sessions` sends exactly this. httplib alone would
  // wait for a body until its read timeout.
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  const auto start = std::chrono::steady_clock::now();
  const std::string answer = exchangeRaw(
      server.port(), "POST /v1/sessions HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(answer.rfind("HTTP/1.1 201", 0) == 0);
  CHECK(answer.find("\"token\"") != std::string::npos);
  CHECK(seconds < 2.0);
  ApiClient api(server);
  Reply info = api.get("/v1/info");
  CHECK(info.json["validation"]["messages"] == 0);
}

namespace {
}  // namespace

TEST_CASE("api: two sessions cannot see or change each other") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession a = createSession(api);
  TestSession b = createSession(api);
  CHECK(a.id != b.id);
  CHECK(a.token != b.token);

  const std::vector<std::pair<std::string, std::string>> routes = {
      {"GET", ""},           {"GET", "/camera"},    {"GET", "/settings"},
      {"GET", "/materials"}, {"GET", "/lights"},    {"DELETE", "/lights"},
      {"DELETE", ""},        {"POST", "/camera/frame"}};
  for (const auto& [method, suffix] : routes) {
    const std::string what = method + " " + suffix;
    // No token, a malformed one, a well-formed token of no session: 401.
    checkProblem(api.send(method, a.path() + suffix, "", {}), 401, "unauthorized", what);
    checkProblem(api.send(method, a.path() + suffix, "", {{"Authorization", "Basic abc"}}), 401,
                 "unauthorized", what + " (Basic)");
    checkProblem(api.send(method, a.path() + suffix, "", {{"Authorization", "Bearer"}}), 401,
                 "unauthorized", what + " (empty bearer)");
    checkProblem(api.send(method, a.path() + suffix, "",
                          {{"Authorization", "Bearer " + std::string(64, '0')}}),
                 401, "unauthorized", what + " (unknown token)");
    // B's token on A: 403. An unknown session id: 404.
    checkProblem(api.send(method, a.path() + suffix, "", {{"Authorization", "Bearer " + b.token}}),
                 403, "forbidden", what + " (other session's token)");
    checkProblem(api.send(method, "/v1/sessions/s-0000000000000000" + suffix, "",
                          {{"Authorization", "Bearer " + a.token}}),
                 404, "not-found", what + " (unknown session)");
  }
  // ?token= is for frames and streams only.
  checkProblem(api.get(a.path() + "?token=" + a.token), 401, "unauthorized", "?token= on GET session");

  // A's edits do not reach B.
  REQUIRE(api.patch(a.path() + "/settings", R"({"exposure": 7})", a.token).status == 200);
  REQUIRE(api.post(a.path() + "/lights/generate", R"({"count": 50, "seed": 1})", a.token).status ==
          200);
  CHECK(api.get(b.path() + "/settings", b.token).json.at("exposure") == 1);
  CHECK(api.get(b.path() + "/lights", b.token).json.at("total") == 4);
  CHECK(api.get(a.path() + "/lights", a.token).json.at("total") == 50);
  // Nothing was changed by the refused requests above.
  CHECK(api.get(b.path(), b.token).status == 200);

  // A deleted session: its token is no longer any session's.
  REQUIRE(api.del(a.path(), a.token).status == 204);
  checkProblem(api.get(a.path(), a.token), 404, "not-found", "deleted session, own token");
  checkProblem(api.get(b.path(), a.token), 401, "unauthorized", "deleted session's token on B");
  CHECK(api.get(b.path(), b.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: request bodies are checked against the schemas, naming the member") {
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string light = s.path() + "/lights/" +
                            std::to_string(api.get(s.path() + "/lights", s.token)
                                               .json["lights"][0]["id"]
                                               .get<uint64_t>());
  struct Case {
    std::string method, suffix, body, pointer;
  };
  const std::vector<Case> cases = {
      // Not JSON, wrong top-level type.
      {"PATCH", "/settings", "{", ""},
      {"PATCH", "/settings", "[]", ""},
      // Camera: missing, wrong type, out of range, unknown member, cross-member rules.
      {"PUT", "/camera", R"({"eye":[0,1,2],"target":[0,0,0],"up":[0,1,0],"fovY":50,"near":0.1})", "/far"},
      {"PUT", "/camera", R"({"eye":[0,1,"x"],"target":[0,0,0],"up":[0,1,0],"fovY":50,"near":0.1,"far":9})", "/eye/2"},
      {"PATCH", "/camera", R"({"fovY": 180})", "/fovY"},
      {"PATCH", "/camera", R"({"fovY": 0.5})", "/fovY"},
      {"PATCH", "/camera", R"({"near": 0})", "/near"},
      {"PATCH", "/camera", R"({"eye": [1, 2]})", "/eye"},
      {"PATCH", "/camera", R"({"zoom": 2})", "/zoom"},
      {"PATCH", "/camera", R"({"near": 5, "far": 4})", "/far"},
      {"PATCH", "/camera", R"({"eye": [0, 0, 0], "target": [0, 0, 0]})", "/target"},
      {"PATCH", "/camera", R"({"eye": [0, 5, 0], "target": [0, 0, 0], "up": [0, 1, 0]})", "/up"},
      // Settings.
      {"PATCH", "/settings", R"({"exposure": 0})", "/exposure"},
      {"PATCH", "/settings", R"({"exposure": 1001})", "/exposure"},
      {"PATCH", "/settings", R"({"technique": "forward"})", "/technique"},
      {"PATCH", "/settings", R"({"markers": 1})", "/markers"},
      {"PATCH", "/settings", R"({"antialias": "msaa"})", "/antialias"},
      {"PATCH", "/settings", R"({"sun": {"intensity": -1}})", "/sun/intensity"},
      {"PATCH", "/settings", R"({"sun": {"direction": [0, 0, 0]}})", "/sun/direction"},
      {"PATCH", "/settings", R"({"sun": {"spin": 1}})", "/sun/spin"},
      {"PATCH", "/settings", R"({"ambient": [0, 0, 65]})", "/ambient/2"},
      {"PATCH", "/settings", R"({"fog": true})", "/fog"},
      // Materials.
      {"PATCH", "/materials/0", R"({"metallic": 2})", "/metallic"},
      {"PATCH", "/materials/0", R"({"baseColor": [0.5, 0.5, 1.5]})", "/baseColor/2"},
      {"PATCH", "/materials/0", R"({"name": "x"})", "/name"},
      {"PATCH", "/materials/0", R"({"clearcoat": 1.5})", "/clearcoat"},
      {"PATCH", "/materials/0", R"({"sheenColor": [0.5, 0.5, 1.5]})", "/sheenColor/2"},
      {"PATCH", "/materials/0", R"({"ior": 0})", "/ior"},
      // Lights.
      {"POST", "/lights", R"({"lights": []})", "/lights"},
      {"POST", "/lights", R"({})", "/lights"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 0, "color": [1,1,1], "intensity": 1, "falloff": 1}]})", "/lights/0/radius"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1}]})", "/lights/0/falloff"},
      {"POST", "/lights", R"({"lights": [{"id": 3, "position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1}]})", "/lights/0/id"},
      {"PATCH", light, R"({"intensity": 1000001})", "/intensity"},
      // Spot lights and falloff modes: the schema's ranges, then inner < outer across members.
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "type": "spot", "innerConeAngle": 0.6, "outerConeAngle": 0.5}]})", "/lights/0/innerConeAngle"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "type": "spot", "innerConeAngle": 0.5, "outerConeAngle": 0.5}]})", "/lights/0/innerConeAngle"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "outerConeAngle": 1.6}]})", "/lights/0/outerConeAngle"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "outerConeAngle": 0}]})", "/lights/0/outerConeAngle"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "innerConeAngle": -0.1}]})", "/lights/0/innerConeAngle"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "innerConeAngle": 1e999}]})", ""},  // refused while parsing
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "innerConeAngle": NaN}]})", ""},  // not JSON
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "type": "area"}]})", "/lights/0/type"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "attenuation": "linear"}]})", "/lights/0/attenuation"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "type": "spot", "direction": [0,0,0]}]})", "/lights/0/direction"},
      {"POST", "/lights", R"({"lights": [{"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1}, {"position": [0,0,0], "radius": 1, "color": [1,1,1], "intensity": 1, "falloff": 1, "type": "spot", "innerConeAngle": 0.9}]})", "/lights/1/innerConeAngle"},
      {"PATCH", light, R"({"innerConeAngle": 1.0})", "/innerConeAngle"},
      {"PATCH", light, R"({"innerConeAngle": 0.3, "outerConeAngle": 0.2})", "/innerConeAngle"},
      {"PATCH", light, R"({"type": "spot", "direction": [0, 0, 0]})", "/direction"},
      {"PATCH", light, R"({"outerConeAngle": "wide"})", "/outerConeAngle"},
      {"PATCH", "/settings", R"({"suns": [{"direction": [0, 0, 0], "color": [1, 1, 1], "intensity": 1}]})", "/suns/0/direction"},
      {"PATCH", "/settings", R"({"suns": [{"direction": [0, -1, 0], "color": [1, 1, 1], "intensity": 1001}]})", "/suns/0/intensity"},
      {"PATCH", "/settings", R"({"suns": [{"direction": [0, -1, 0], "color": [1, 1, 1], "intensity": 1}, {"direction": [0, -1, 0], "color": [1, 1, 1], "intensity": 1}, {"direction": [0, -1, 0], "color": [1, 1, 1], "intensity": 1}, {"direction": [0, -1, 0], "color": [1, 1, 1], "intensity": 1}]})", "/suns"},
      {"POST", "/camera/select", R"({"modelCamera": 0})", "/modelCamera"},  // the built-in scene has none
      {"POST", "/camera/select", R"({"modelCamera": -1})", "/modelCamera"},
      {"POST", "/camera/select", R"({})", "/modelCamera"},
      {"PATCH", light, R"({"color": [2, 0, 0]})", "/color/0"},
      {"PATCH", light, R"({"id": 9})", "/id"},
      {"POST", "/lights/generate", R"({"seed": 1})", "/count"},
      {"POST", "/lights/generate", R"({"count": 0, "seed": 1})", "/count"},
      {"POST", "/lights/generate", R"({"count": 1, "seed": -1})", "/seed"},
      {"POST", "/lights/generate", R"({"count": 1, "seed": 1, "radius": [2, 1]})", "/radius/1"},
      {"POST", "/lights/generate", R"({"count": 1, "seed": 1, "bounds": {"min": [0, 0, 0], "max": [1, -1, 1]}})", "/bounds/max/1"},
      {"POST", "/lights/generate", R"({"count": 1, "seed": 1, "replace": "yes"})", "/replace"},
      // Model and session creation.
      {"PUT", "/model", R"({"source": "http://example.com/a.glb"})", "/source"},
      {"PUT", "/model", R"({})", "/source"},
  };
  for (const Case& c : cases) {
    const std::string path = c.suffix.starts_with("/v1/") ? c.suffix : s.path() + c.suffix;
    Reply reply = api.send(c.method, path, c.body, {{"Authorization", "Bearer " + s.token}},
                           "application/json");
    checkProblem(reply, 400, "invalid-body", c.method + " " + c.suffix + " " + c.body, c.pointer);
  }
  checkProblem(api.post("/v1/sessions", R"({"model": 3})"), 400, "invalid-body",
               "POST /v1/sessions model 3", "/model");
  checkProblem(api.post("/v1/sessions", R"({"lights": 3})"), 400, "invalid-body",
               "POST /v1/sessions unknown member", "/lights");
  checkProblem(api.post(s.path() + "/camera/frame", R"({"x": 1})", s.token), 400, "invalid-body",
               "POST camera/frame with a body", "");

  // Content types and query parameters.
  checkProblem(api.patch(s.path() + "/settings", R"({"exposure": 2})", s.token, "text/plain"), 415,
               "unsupported-media-type", "PATCH settings as text/plain");
  checkProblem(api.post("/v1/sessions", "{}", "", "application/x-www-form-urlencoded"), 415,
               "unsupported-media-type", "POST /v1/sessions as a form (curl -d)");
  checkProblem(api.patch(s.path() + "/settings", R"({"exposure": 2})", s.token,
                         "application/x-www-form-urlencoded"),
               415, "unsupported-media-type", "PATCH settings as a form");
  checkProblem(api.put(s.path() + "/model", "abc", s.token, "text/plain"), 415,
               "unsupported-media-type", "PUT model as text/plain");
  checkProblem(api.put(s.path() + "/model", "abc", s.token, "application/octet-stream"), 400,
               "invalid-parameter", "upload without filename", std::nullopt, std::nullopt,
               "filename");
  checkProblem(api.get(s.path() + "/settings?verbose=1", s.token), 400, "unknown-parameter",
               "GET settings?verbose", std::nullopt, std::nullopt, "verbose");
  checkProblem(api.get(s.path() + "/lights?limit=1001", s.token), 400, "invalid-parameter",
               "lights?limit=1001", std::nullopt, std::nullopt, "limit");
  checkProblem(api.get(s.path() + "/lights?offset=-1", s.token), 400, "invalid-parameter",
               "lights?offset=-1", std::nullopt, std::nullopt, "offset");
  checkProblem(api.put(s.path() + "/model?lights=all", R"({"source":"builtin:default"})", s.token),
               400, "invalid-parameter", "model?lights=all", std::nullopt, std::nullopt, "lights");

  // Methods and paths.
  Reply wrongMethod = api.put(s.path() + "/settings", "{}", s.token);
  checkProblem(wrongMethod, 405, "method-not-allowed", "PUT settings");
  CHECK(wrongMethod.header("Allow") == "GET, HEAD, PATCH, OPTIONS");
  checkProblem(api.get(s.path() + "/nothing", s.token), 404, "not-found", "GET unknown route");
  checkProblem(api.get(s.path() + "/lights/999999", s.token), 404, "not-found", "GET light 999999");
  checkProblem(api.get(s.path() + "/lights/abc", s.token), 404, "not-found", "GET light abc");

  // Nothing above changed the session.
  CHECK(api.get(s.path() + "/settings", s.token).json == s.created["session"]["settings"]);
  CHECK(api.get(s.path() + "/camera", s.token).json == s.created["session"]["camera"]);
  CHECK(api.get(s.path() + "/lights", s.token).json["total"] == 2);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: limits answer 413 and 429 with the limit's name") {
  ServerProcess server({"--lights", "2", "--max-sessions", "2", "--max-lights", "1000",
                        "--max-upload-bytes", "100000", "--max-body-bytes", "4096"});
  requireListening(server);
  ApiClient api(server);
  Reply info = api.get("/v1/info");
  CHECK(info.json["limits"]["maxSessions"] == 2);
  CHECK(info.json["limits"]["maxLightsPerSession"] == 1000);
  CHECK(info.json["limits"]["maxUploadBytes"] == 100000);
  CHECK(info.json["limits"]["maxBodyBytes"] == 4096);

  TestSession s = createSession(api);
  TestSession t = createSession(api);
  checkProblem(api.post("/v1/sessions", "{}"), 429, "limit-exceeded", "third session", std::nullopt,
               "maxSessions");
  REQUIRE(api.del(t.path(), t.token).status == 204);
  TestSession u = createSession(api);  // the freed place can be taken again

  // Lights past maxLightsPerSession: generate, add, and keep-adding.
  checkProblem(api.post(s.path() + "/lights/generate", R"({"count": 1001, "seed": 1})", s.token),
               413, "limit-exceeded", "generate 1001", std::nullopt, "maxLightsPerSession");
  REQUIRE(api.post(s.path() + "/lights/generate", R"({"count": 999, "seed": 1})", s.token).status ==
          200);
  checkProblem(api.post(s.path() + "/lights/generate",
                        R"({"count": 2, "seed": 1, "replace": false})", s.token),
               413, "limit-exceeded", "generate 2 more", std::nullopt, "maxLightsPerSession");
  json two = {{"lights", {lightJson(0), lightJson(1)}}};
  checkProblem(api.post(s.path() + "/lights", two.dump(), s.token), 413, "limit-exceeded",
               "add 2 to 999", std::nullopt, "maxLightsPerSession");
  json one = {{"lights", {lightJson(0)}}};
  REQUIRE(api.post(s.path() + "/lights", one.dump(), s.token).status == 201);
  CHECK(api.get(s.path() + "/lights", s.token).json["total"] == 1000);

  // Bodies: an upload over maxUploadBytes, JSON over maxBodyBytes (also on the model route).
  checkProblem(api.put(s.path() + "/model?filename=big.glb", std::string(150000, 'x'), s.token,
                       "application/octet-stream"),
               413, "limit-exceeded", "upload 150000", std::nullopt, "maxUploadBytes");
  std::string bigJson = R"({"exposure": 1)" + std::string(5000, ' ') + "}";
  checkProblem(api.patch(s.path() + "/settings", bigJson, s.token), 413, "limit-exceeded",
               "5000-byte JSON", std::nullopt, "maxBodyBytes");
  std::string bigSource = R"({"source": "builtin:default")" + std::string(5000, ' ') + "}";
  checkProblem(api.put(s.path() + "/model", bigSource, s.token), 413, "limit-exceeded",
               "5000-byte model JSON", std::nullopt, "maxBodyBytes");
  // Under the upload limit, a file that is not a model is the loader's to reject.
  checkProblem(api.put(s.path() + "/model?filename=junk.glb", std::string(50000, 'x'), s.token,
                       "application/octet-stream"),
               422, "model-rejected", "50000 bytes of junk");
  CHECK(api.get("/v1/health").status == 200);
  CHECK(api.get(u.path(), u.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: requests in flight past --max-requests get 429") {
  ServerProcess server({"--lights", "2", "--max-requests", "1"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  // A large frame keeps one request in flight for a while on any device; meanwhile every other
  // counted request is refused. The health probe is never counted.
  std::atomic<bool> frameDone{false};
  auto frame = std::async(std::launch::async, [&] {
    ApiClient other(server);
    // The polling below may hold the one place when the frame arrives: then the frame is refused
    // and tries again.
    Reply reply;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      reply = other.get("/v1/frame?width=2048&height=2048");
      if (reply.status != 429) break;
    }
    frameDone = true;
    return reply.status;
  });
  bool refused = false;
  while (!frameDone && !refused) {
    Reply reply = api.get(s.path() + "/settings", s.token);
    if (reply.status == 429) {
      checkProblem(reply, 429, "limit-exceeded", "second request in flight", std::nullopt,
                   "maxRequestsInFlight");
      refused = true;
      CHECK(api.get("/v1/health").status == 200);
    } else {
      CHECK(reply.status == 200);
    }
  }
  CHECK(frame.get() == 200);
  CHECK(refused);
  CHECK(api.get(s.path() + "/settings", s.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: every invalid and glTF2 test file uploaded in turn: 200 or 422, never a dead server") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  std::vector<fs::path> files;
  for (const char* dir : {"invalid", "glTF2"}) {
    for (const auto& entry : fs::recursive_directory_iterator(kAssimpModels / dir)) {
      if (entry.is_regular_file()) files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  REQUIRE(files.size() > 50);
  size_t accepted = 0, rejected = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const fs::path& file : files) {
    const std::string name = file.filename().string();
    Reply reply = api.put(s.path() + "/model?filename=" + name,
                          readFile(file), s.token, "application/octet-stream");
    INFO(file.string(), " -> ", reply.status, " ", reply.body.substr(0, 300));
    CHECK((reply.status == 200 || reply.status == 422));
    if (reply.status == 200) {
      ++accepted;
      CHECK(reply.json.at("model").at("source") == "upload:" + name);
      CHECK(reply.json.at("lights").at("count") == 4);  // kept
    } else if (reply.status == 422) {
      ++rejected;
      checkProblem(reply, 422, "model-rejected", file.string());
    }
    REQUIRE(api.get("/v1/health").status == 200);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE(files.size(), " files: ", accepted, " loaded, ", rejected, " rejected, in ", seconds,
          " s");
  // Most glTF2 samples are .gltf files naming a .bin beside them (an upload is one file: rejected),
  // or the images and buffers themselves; the self-contained .glb files load.
  CHECK(accepted >= 5);
  CHECK(rejected >= 50);
  // The session still works and the GPU saw no invalid use.
  CHECK(api.put(s.path() + "/model", R"({"source":"builtin:default"})", s.token).status == 200);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: library names outside --models are 404") {
  ModelDir models;
  ServerProcess server({"--lights", "2", "--models", models.root.string()});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api, R"({"model": "library:box.glb"})");
  CHECK(s.created["session"]["model"]["source"] == "library:box.glb");
  for (const std::string name :
       {"../box.glb", "/etc/passwd", "sub/../../etc/passwd", "missing.glb", ".hidden.glb",
        "sub", "box.glb/x", "sub\\box2.glb"}) {
    checkProblem(api.put(s.path() + "/model", json{{"source", "library:" + name}}.dump(), s.token),
                 404, "not-found", "library:" + name);
    checkProblem(api.post("/v1/sessions", json{{"model", "library:" + name}}.dump()), 404,
                 "not-found", "POST session library:" + name);
  }
  // A failed create leaves no session behind.
  CHECK(api.get("/v1/info").json["sessions"]["open"] == 1);
  checkStopsCleanly(server);
}

TEST_CASE("api: without --models the library is empty") {
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  CHECK(api.get("/v1/models").json == json{{"models", json::array()}});
  checkProblem(api.post("/v1/sessions", R"({"model": "library:box.glb"})"), 404, "not-found",
               "library without --models");
  checkStopsCleanly(server);
}

TEST_CASE("api: idle sessions expire; requests keep them alive") {
  ServerProcess server({"--lights", "2", "--session-idle-seconds", "1"});
  requireListening(server);
  ApiClient api(server);
  TestSession idle = createSession(api);
  TestSession busy = createSession(api);
  CHECK(idle.created["expiresInSeconds"] == 1);
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(2500)) {
    REQUIRE(api.get(busy.path() + "/camera", busy.token).status == 200);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  checkProblem(api.get(idle.path(), idle.token), 404, "not-found", "expired session");
  CHECK(api.get(busy.path(), busy.token).status == 200);
  CHECK(api.get("/v1/info").json["sessions"]["open"] == 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  checkProblem(api.get(busy.path(), busy.token), 404, "not-found", "expired after idling");
  CHECK(api.get("/v1/info").json["sessions"]["open"] == 0);
  CHECK(server.stderrText().find("expired") != std::string::npos);
  checkStopsCleanly(server);
}

TEST_CASE("api: DELETE frees the session's GPU memory before it answers") {
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  const uint64_t before = gpuMemory(api);
  TestSession s = createSession(api);
  // A million lights: the default maxLightsPerSession, exactly.
  const auto start = std::chrono::steady_clock::now();
  REQUIRE(api.post(s.path() + "/lights/generate", R"({"count": 1000000, "seed": 3})", s.token)
              .status == 200);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t during = gpuMemory(api);
  MESSAGE("GPU memory: ", before, " bytes before, ", during,
          " with a session of 1000000 lights (generated and uploaded in ", seconds, " s)");
  CHECK(during > before + 1000000ull * 32);  // at least the lights themselves
  checkProblem(api.post(s.path() + "/lights/generate", R"({"count": 1, "seed": 3, "replace": false})",
                        s.token),
               413, "limit-exceeded", "the millionth-and-first light", std::nullopt,
               "maxLightsPerSession");
  Reply last = api.get(s.path() + "/lights?offset=999999", s.token);
  REQUIRE(last.status == 200);
  CHECK(last.json["total"] == 1000000);
  REQUIRE(last.json["lights"].size() == 1);
  const std::string lastLight =
      s.path() + "/lights/" + std::to_string(last.json["lights"][0]["id"].get<uint64_t>());
  const uint64_t firstId =
      api.get(s.path() + "/lights?limit=1", s.token).json["lights"][0]["id"].get<uint64_t>();
  CHECK(api.del(s.path() + "/lights/" + std::to_string(firstId), s.token).status == 204);
  CHECK(api.get(lastLight, s.token).status == 200);  // moved into the hole, same id
  CHECK(api.get(s.path() + "/lights?offset=0&limit=1", s.token).json["lights"][0] ==
        api.get(lastLight, s.token).json);
  REQUIRE(api.del(s.path(), s.token).status == 204);
  CHECK(gpuMemory(api) == before);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: --api-key / MYRIAD_API_KEY guard session creation; CORS preflights") {
  setenv("MYRIAD_API_KEY", "env-key-12345", 1);
  ServerProcess fromEnv({"--lights", "2"});
  unsetenv("MYRIAD_API_KEY");
  requireListening(fromEnv);
  {
    ApiClient api(fromEnv);
    CHECK(api.get("/v1/info").json["apiKeyRequired"] == true);
    checkProblem(api.post("/v1/sessions", "{}"), 401, "unauthorized", "no key");
    checkProblem(api.post("/v1/sessions", "{}", "wrong-key-123"), 401, "unauthorized", "wrong key");
    createSession(api, "{}", "env-key-12345");
  }
  checkStopsCleanly(fromEnv);

  ServerProcess server({"--lights", "2", "--api-key", "flag-key-12345", "--cors-origin",
                        "http://app.test"});
  requireListening(server);
  ApiClient api(server);
  checkProblem(api.post("/v1/sessions", "{}", "env-key-12345"), 401, "unauthorized", "env key");
  TestSession s = createSession(api, "{}", "flag-key-12345");
  // The key is not a session token.
  checkProblem(api.get(s.path(), "flag-key-12345"), 401, "unauthorized", "key as a token");

  Reply preflight = api.send("OPTIONS", s.path() + "/lights",
                             "", {{"Origin", "http://app.test"},
                                  {"Access-Control-Request-Method", "POST"}});
  CHECK(preflight.status == 204);
  CHECK(preflight.header("Access-Control-Allow-Origin") == "http://app.test");
  CHECK(preflight.header("Access-Control-Allow-Methods").find("POST") != std::string::npos);
  CHECK(preflight.header("Access-Control-Allow-Headers").find("Authorization") !=
        std::string::npos);
  Reply allowed = api.send("GET", s.path(), "",
                           {{"Origin", "http://app.test"}, {"Authorization", "Bearer " + s.token}});
  CHECK(allowed.status == 200);
  CHECK(allowed.header("Access-Control-Allow-Origin") == "http://app.test");
  Reply other = api.send("GET", s.path(), "",
                         {{"Origin", "http://evil.test"}, {"Authorization", "Bearer " + s.token}});
  CHECK(other.status == 200);
  CHECK(other.header("Access-Control-Allow-Origin").empty());
  checkStopsCleanly(server);
}

TEST_CASE("api: light edits reach the GPU exactly (a session edited piecemeal renders like one built whole)") {
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  TestSession edited = createSession(api);
  TestSession whole = createSession(api);
  const std::string lights = edited.path() + "/lights";
  REQUIRE(api.post(lights + "/generate", R"({"count": 60, "seed": 11})", edited.token).status ==
          200);
  std::vector<uint64_t> ids;
  const Reply generatedPage = api.get(lights + "?limit=1000", edited.token);
  for (const json& l : generatedPage.json["lights"]) {
    ids.push_back(l["id"].get<uint64_t>());
  }
  REQUIRE(ids.size() == 60);
  // Deletes from the front, middle and back (each moves the last light), patches, appends.
  for (size_t i : {0, 59, 30, 7, 45, 1, 22}) {
    REQUIRE(api.del(lights + "/" + std::to_string(ids[i]), edited.token).status == 204);
  }
  for (size_t i : {2, 3, 40, 58}) {
    REQUIRE(api.patch(lights + "/" + std::to_string(ids[i]),
                      R"({"radius": 3, "color": [0, 0.5, 1], "position": [0.5, 0.5, 0.5]})",
                      edited.token)
                .status == 200);
  }
  REQUIRE(api.post(lights, json{{"lights", {lightJson(-2.0, 2.5), lightJson(2.0, 2.5)}}}.dump(),
                   edited.token)
              .status == 201);
  Reply page = api.get(lights + "?limit=1000", edited.token);
  REQUIRE(page.json["total"] == 55);

  // The same lights, in the same order, added in one request to a fresh session.
  json all = json::array();
  for (json l : page.json["lights"]) {
    l.erase("id");
    all.push_back(l);
  }
  REQUIRE(api.del(whole.path() + "/lights", whole.token).status == 204);
  REQUIRE(api.post(whole.path() + "/lights", json{{"lights", all}}.dump(), whole.token).status ==
          201);
  for (const char* technique : {"clustered", "volumes"}) {
    const std::string patch = json{{"technique", technique}}.dump();
    REQUIRE(api.patch(edited.path() + "/settings", patch, edited.token).status == 200);
    REQUIRE(api.patch(whole.path() + "/settings", patch, whole.token).status == 200);
    const std::string query = "/frame?width=96&height=64&format=png";
    Reply a = api.get(edited.path() + query, edited.token);
    Reply b = api.get(whole.path() + query, whole.token);
    INFO(technique, ": ", a.body.substr(0, 200), " / ", b.body.substr(0, 200));
    REQUIRE(a.status == 200);
    REQUIRE(b.status == 200);
    CHECK(a.body == b.body);
  }
  // The comparison can fail: one light less shows.
  const uint64_t appended = page.json["lights"][53]["id"].get<uint64_t>();
  REQUIRE(api.del(lights + "/" + std::to_string(appended), edited.token).status == 204);
  const std::string query = "/frame?width=96&height=64&format=png";
  CHECK(api.get(edited.path() + query, edited.token).body !=
        api.get(whole.path() + query, whole.token).body);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: concurrent edits of one session stay consistent; deleting it mid-edit is clean") {
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient setup(server);
  TestSession s = createSession(setup);
  REQUIRE(setup.del(s.path() + "/lights", s.token).status == 204);
  constexpr int kThreads = 4, kRounds = 25;
  std::vector<std::future<int>> workers;
  for (int t = 0; t < kThreads; ++t) {
    workers.push_back(std::async(std::launch::async, [&, t] {
      ApiClient api(server);
      int kept = 0;
      for (int round = 0; round < kRounds; ++round) {
        Reply added = api.post(s.path() + "/lights",
                               json{{"lights", {lightJson(t), lightJson(-t)}}}.dump(), s.token);
        if (added.status != 201) return -1;
        const std::string first = s.path() + "/lights/" + std::to_string(added.json["ids"][0].get<uint64_t>());
        if (api.patch(first, R"({"intensity": 5})", s.token).status != 200) return -1;
        if (api.del(first, s.token).status != 204) return -1;
        ++kept;
      }
      return kept;
    }));
  }
  int kept = 0;
  for (auto& w : workers) {
    int n = w.get();
    CHECK(n == kRounds);
    kept += n;
  }
  Reply page = setup.get(s.path() + "/lights?limit=1000", s.token);
  CHECK(page.json["total"] == kept);
  std::set<uint64_t> ids;
  for (const json& l : page.json["lights"]) ids.insert(l["id"].get<uint64_t>());
  CHECK(ids.size() == size_t(kept));
  CHECK(setup.get(s.path() + "/frame?width=64&height=48", s.token).status == 200);

  // A model replacement racing a DELETE: either finishes first; the other gets 404 or its answer.
  auto replace = std::async(std::launch::async, [&] {
    ApiClient api(server);
    return api.put(s.path() + "/model?filename=box.glb", readFile(kBox), s.token,
                   "application/octet-stream")
        .status;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK(setup.del(s.path(), s.token).status == 204);
  const int replaced = replace.get();
  CHECK((replaced == 200 || replaced == 404));
  checkProblem(setup.get(s.path(), s.token), 404, "not-found", "deleted during a model load");
  CHECK(setup.get("/v1/info").json["sessions"]["open"] == 0);
  CHECK(myriad::test::validationMessages(setup) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: a model with its files, as a zip or as several files; hostile archives are 422") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const fs::path box = kAssimpModels / "glTF2/BoxTextured-glTF";
  REQUIRE(fs::exists(box / "BoxTextured.gltf"));
  const std::string gltf = readFile(box / "BoxTextured.gltf");
  const std::string bin = readFile(box / "BoxTextured0.bin");
  const std::string png = readFile(box / "CesiumLogoFlat.png");

  // A zip of the .gltf, its .bin and its image, in a folder.
  Reply zip = api.put(s.path() + "/model?filename=box.zip",
                      myriad::test::makeZip({{"box/BoxTextured.gltf", gltf},
                                     {"box/BoxTextured0.bin", bin},
                                     {"box/CesiumLogoFlat.png", png}}),
                      s.token, "application/zip");
  INFO(zip.body.substr(0, 300));
  REQUIRE(zip.status == 200);
  CHECK(zip.json.at("model").at("source") == "upload:box.zip");
  CHECK(zip.json.at("model").at("meshes") == 1);
  CHECK(zip.json.at("lights").at("count") == 4);

  // The same three files as multipart/form-data, as a browser sends a multi-file pick.
  httplib::Client client(server.host(), server.port());
  client.set_bearer_token_auth(s.token.c_str());
  client.set_read_timeout(120, 0);
  auto parts = client.Put((s.path() + "/model").c_str(),
                          httplib::MultipartFormDataItems{
                              {"files", gltf, "BoxTextured.gltf", "model/gltf+json"},
                              {"files", bin, "BoxTextured0.bin", "application/octet-stream"},
                              {"files", png, "CesiumLogoFlat.png", "image/png"}});
  REQUIRE(parts);
  INFO(parts->body.substr(0, 300));
  CHECK(parts->status == 200);
  CHECK(json::parse(parts->body).at("model").at("source") == "upload:BoxTextured.gltf");

  // Each hostile or broken upload: 422 model-rejected whose detail names the problem.
  struct Bad {
    std::string what;
    std::string zip;
    std::string entry;
    std::string named;
  };
  const std::vector<Bad> bad = {
      {"missing .bin", myriad::test::makeZip({{"BoxTextured.gltf", gltf}}), "", "BoxTextured0.bin"},
      {"..", myriad::test::makeZip({{"../BoxTextured.gltf", gltf}}), "", "leaves the archive"},
      {"absolute", myriad::test::makeZip({{"/tmp/BoxTextured.gltf", gltf}}), "", "absolute path"},
      {"symlink", myriad::test::makeZip({{"BoxTextured.gltf", gltf}, {"BoxTextured0.bin", "/etc/passwd", true}}),
       "", "symbolic link"},
      {"bomb", myriad::test::makeZip({{"BoxTextured.gltf", gltf}, {"BoxTextured0.bin", std::string(64u << 20, '\0')}}),
       "", "maxCompressionRatio"},
      {"two models", myriad::test::makeZip({{"a.gltf", gltf}, {"b.gltf", gltf}, {"BoxTextured0.bin", bin}}), "",
       "entry parameter"},
      {"no such entry", myriad::test::makeZip({{"a.gltf", gltf}}), "c.gltf", "'c.gltf'"},
      {"not a zip", "PK but nothing more", "", "not a zip archive"},
  };
  // The server's own memory (the archive is inflated, if at all, in the loader child).
  const unsigned long long residentBefore = server.residentBytes();
  REQUIRE(residentBefore > 0);
  for (const Bad& b : bad) {
    CAPTURE(b.what);
    Reply reply = api.put(s.path() + "/model?filename=bad.zip" + (b.entry.empty() ? "" : "&entry=" + b.entry),
                          b.zip, s.token, "application/zip");
    checkProblem(reply, 422, "model-rejected", b.what);
    CHECK_MESSAGE(reply.json.value("detail", "").find(b.named) != std::string::npos,
                  reply.json.value("detail", ""));
    REQUIRE(api.get("/v1/health").status == 200);
  }
  const unsigned long long residentAfter = server.residentBytes();
  MESSAGE("server RSS ", residentBefore >> 20, " MiB before the hostile archives, ",
          residentAfter >> 20, " MiB after");
  CHECK(residentAfter <= residentBefore + (64ull << 20));
  // ?entry= picks one of several models; it belongs to uploads of several files only.
  Reply picked = api.put(s.path() + "/model?filename=two.zip&entry=b.gltf",
                         myriad::test::makeZip({{"a.gltf", gltf}, {"b.gltf", gltf}, {"BoxTextured0.bin", bin},
                                                {"CesiumLogoFlat.png", png}}),
                         s.token, "application/zip");
  CHECK(picked.status == 200);
  checkProblem(api.put(s.path() + "/model?filename=a.glb&entry=x", "abc", s.token,
                       "application/octet-stream"),
               400, "invalid-parameter", "entry", std::nullopt, std::nullopt, "entry");
  // The failed uploads changed nothing: the session shows the last model it loaded.
  Reply state = api.get(s.path(), s.token);
  CHECK(state.json.at("model").at("source") == "upload:two.zip");
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: generated lights follow a new model; edited lights stay; ?lights= decides") {
  ServerProcess server({"--lights", "6"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const auto lightsOf = [&] { return api.get(s.path() + "/lights?limit=1000", s.token).json.at("lights"); };
  const json builtinLights = lightsOf();
  REQUIRE(builtinLights.size() == 6);

  // The spider (hundreds of units across): the built-in scene's lights are made again around it.
  Reply spider = api.put(s.path() + "/model?filename=spider.obj", readFile(kAssimpModels / "OBJ/spider.obj"),
                         s.token, "application/octet-stream");
  REQUIRE(spider.status == 200);
  CHECK(spider.json.at("lights").at("count") == 6);
  const json& bounds = spider.json.at("model").at("bounds");
  double diagonal = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double extent = bounds["max"][axis].get<double>() - bounds["min"][axis].get<double>();
    diagonal += extent * extent;
  }
  diagonal = std::sqrt(diagonal);
  const json fitted = lightsOf();
  REQUIRE(fitted.size() == 6);
  for (const json& l : fitted) {
    for (int axis = 0; axis < 3; ++axis) {
      const double p = l["position"][axis].get<double>();
      CHECK(p >= bounds["min"][axis].get<double>() - 0.2 * diagonal);
      CHECK(p <= bounds["max"][axis].get<double>() + 0.2 * diagonal);
    }
    CHECK(l["radius"].get<double>() >= 0.04 * diagonal - 1e-3);  // sized to the spider
  }
  CHECK(fitted[0]["id"] != builtinLights[0]["id"]);

  // An edit makes them the user's: the next model keeps them as they are.
  const std::string firstLight = s.path() + "/lights/" + to_string(fitted[0]["id"]);
  REQUIRE(api.patch(firstLight, R"({"intensity": 9})", s.token).status == 200);
  const json edited = lightsOf();
  Reply box = api.put(s.path() + "/model", R"({"source": "builtin:default"})", s.token);
  REQUIRE(box.status == 200);
  CHECK(lightsOf() == edited);
  // ?lights=fit makes them again anyway; a bad value names the parameter.
  REQUIRE(api.put(s.path() + "/model?lights=fit", R"({"source": "builtin:default"})", s.token).status == 200);
  CHECK(lightsOf() != edited);
  CHECK(lightsOf().size() == 6);
  checkProblem(api.put(s.path() + "/model?lights=all", R"({"source": "builtin:default"})", s.token), 400,
               "invalid-parameter", "lights=all", std::nullopt, std::nullopt, "lights");
  checkStopsCleanly(server);
}

TEST_CASE("api: a snapshot restores a session in a new one (the same frame) or onto another") {
  ServerProcess server({"--lights", "8"});
  requireListening(server);
  ApiClient api(server);
  TestSession a = createSession(api);
  // Edit everything a snapshot holds.
  REQUIRE(api.patch(a.path() + "/camera", R"({"fovY": 35, "eye": [4, 3, 5]})", a.token).status == 200);
  REQUIRE(api.patch(a.path() + "/settings", R"({"exposure": 1.4, "technique": "tiled", "markers": false})",
                    a.token).status == 200);
  REQUIRE(api.patch(a.path() + "/materials/0", R"({"roughness": 0.2, "baseColor": [0.9, 0.2, 0.1]})",
                    a.token).status == 200);
  REQUIRE(api.post(a.path() + "/lights", "{\"lights\": [" + lightJson(0.5, 2.0).dump() + "]}", a.token)
              .status == 201);
  Reply snapshot = api.get(a.path() + "/snapshot", a.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json.at("lights").at("list").size() == 9);  // 8 generated + 1 added: listed

  // A new session from it: the same state and, pixel for pixel, the same frame.
  Reply created = api.post("/v1/sessions", json{{"snapshot", snapshot.json}}.dump());
  REQUIRE(created.status == 201);
  TestSession b{created.json.at("id"), created.json.at("token"), created.json};
  CHECK(api.get(b.path() + "/snapshot", b.token).json == snapshot.json);
  const std::string frame = "/frame?format=png&width=160&height=90";
  Reply frameA = api.get(a.path() + frame, a.token);
  Reply frameB = api.get(b.path() + frame, b.token);
  REQUIRE(frameA.status == 200);
  REQUIRE(frameB.status == 200);
  CHECK(frameA.body == frameB.body);

  // Onto a third session with the same model: PUT .../snapshot.
  TestSession c = createSession(api);
  Reply put = api.put(c.path() + "/snapshot", snapshot.body, c.token);
  REQUIRE(put.status == 200);
  CHECK(put.json.at("lights").at("count") == 9);
  CHECK(api.get(c.path() + "/snapshot", c.token).json == snapshot.json);

  // Refusals name the member; nothing changes.
  json bad = snapshot.json;
  bad["camera"]["far"] = 0.01;
  bad["camera"]["near"] = 0.02;
  checkProblem(api.put(c.path() + "/snapshot", bad.dump(), c.token), 400, "invalid-body", "far < near",
               "/camera/far");
  bad = snapshot.json;
  bad["model"]["source"] = "upload:mine.glb";
  checkProblem(api.post("/v1/sessions", json{{"snapshot", bad}}.dump()), 400, "invalid-body",
               "uploaded model", "/snapshot/model/source");
  checkProblem(api.post("/v1/sessions", json{{"snapshot", snapshot.json}, {"model", "builtin:default"}}.dump()),
               400, "invalid-body", "both", "/snapshot");
  CHECK(api.get(c.path() + "/snapshot", c.token).json == snapshot.json);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: --state-dir: a session survives a restart, token and upload included") {
  char dirTemplate[] = "/tmp/myriad-state-XXXXXX";
  REQUIRE(mkdtemp(dirTemplate) != nullptr);
  const fs::path stateDir = dirTemplate;
  const std::vector<std::string> args = {"--lights", "6", "--state-dir", stateDir.string(),
                                         "--session-idle-seconds", "2"};
  const std::string frameQuery = "/frame?width=96&height=64&format=png";
  TestSession s;
  std::string before;
  {
    ServerProcess first(args);
    requireListening(first);
    ApiClient api(first);
    s = createSession(api);
    // An upload (the bytes must be kept), and edits of every kind the snapshot holds.
    Reply upload = api.put(s.path() + "/model?filename=box.glb&lights=keep", readFile(kBox), s.token,
                           "application/octet-stream");
    REQUIRE(upload.status == 200);
    REQUIRE(api.patch(s.path() + "/camera", R"({"fovY": 35, "eye": [2.5, 2, 3]})", s.token).status == 200);
    REQUIRE(api.patch(s.path() + "/settings", R"({"exposure": 1.4})", s.token).status == 200);
    REQUIRE(api.patch(s.path() + "/materials/0", R"({"baseColor": [0.9, 0.2, 0.1]})", s.token).status == 200);
    REQUIRE(api.post(s.path() + "/lights",
                     R"({"lights": [{"position": [0.5, 1.5, 0.5], "radius": 4, "color": [1, 1, 1], "intensity": 3, "falloff": 1}]})",
                     s.token).status == 201);
    Reply frame = api.get(s.path() + frameQuery, s.token);
    REQUIRE(frame.status == 200);
    before = frame.body;
    std::this_thread::sleep_for(std::chrono::milliseconds(600));  // written within 250 ms
    // The token itself is never written; its hash is.
    const std::string stored = readFile(stateDir / "sessions" / (s.id + ".json"));
    CHECK(stored.find(s.token) == std::string::npos);
    CHECK(stored.find("tokenSha256") != std::string::npos);
    CHECK(stored.find("upload:box.glb") != std::string::npos);
    checkStopsCleanly(first);
  }
  {
    ServerProcess second(args);
    requireListening(second);
    ApiClient api(second);
    // Another session's token or a made-up one does not open it.
    TestSession other = createSession(api);
    checkProblem(api.get(s.path(), other.token), 403, "forbidden", "token");
    // The right token restores it on its first request: the same scene, the same picture.
    Reply state = api.get(s.path(), s.token);
    INFO(second.stderrText().substr(0, 3000));
    REQUIRE(state.status == 200);
    CHECK(state.json.at("model").at("source") == "upload:box.glb");
    CHECK(state.json.at("camera").at("fovY") == 35);
    CHECK(state.json.at("settings").at("exposure") == 1.4);
    CHECK(api.get(s.path() + "/lights", s.token).json.at("total") == 7);
    Reply frame = api.get(s.path() + frameQuery, s.token);
    REQUIRE(frame.status == 200);
    CHECK(frame.body == before);
    // Idle expiry frees memory only: after it, the next request restores the session again.
    std::this_thread::sleep_for(std::chrono::seconds(4));
    Reply again = api.get(s.path(), s.token);
    CHECK(again.status == 200);
    CHECK(second.stderrText().find("session " + s.id + " restored") != std::string::npos);
    // Deleting ends it everywhere: the file goes, and a later server has nothing to restore.
    CHECK(api.del(s.path(), s.token).status == 204);
    CHECK_FALSE(fs::exists(stateDir / "sessions" / (s.id + ".json")));
    checkStopsCleanly(second);
  }
  {
    ServerProcess third(args);
    requireListening(third);
    ApiClient api(third);
    checkProblem(api.get(s.path(), s.token), 404, "not-found", s.id);
    checkStopsCleanly(third);
  }
  fs::remove_all(stateDir);
}

TEST_CASE("api: the model summary names the glTF extensions the server ignores") {
  // A triangle whose material uses KHR_materials_transmission (not honoured) and
  // KHR_materials_emissive_strength (honoured), with a made-up extension listed as used.
  const std::string gltf = R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_transmission", "EXT_made_up"],
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "triangle", "mesh": 0}],
    "materials": [{"name": "velvet", "emissiveFactor": [1, 0, 0],
                   "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1},
                                  "KHR_materials_emissive_strength": {"emissiveStrength": 3}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
    "buffers": [{"byteLength": 36, "uri":
      "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}]
  })";
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  Reply loaded = api.put(s.path() + "/model?filename=velvet.gltf", gltf, s.token,
                         "application/octet-stream");
  REQUIRE(loaded.status == 200);
  CHECK(loaded.json.at("model").at("ignoredExtensions") ==
        json{"EXT_made_up", "KHR_materials_transmission"});
  // GET says the same; the material's strength was read (3, not Assimp's 1).
  CHECK(api.get(s.path(), s.token).json.at("model").at("ignoredExtensions") ==
        json{"EXT_made_up", "KHR_materials_transmission"});
  const json materials = api.get(s.path() + "/materials", s.token).json.at("materials");
  REQUIRE(materials.size() == 1);
  CHECK(materials[0].at("emissiveStrength") == 3.0);
  // A model that uses only what is honoured lists nothing.
  Reply builtin = api.put(s.path() + "/model", R"({"source": "builtin:default"})", s.token);
  REQUIRE(builtin.status == 200);
  CHECK(!builtin.json.at("model").contains("ignoredExtensions"));
}

TEST_CASE("api: a glTF file's point, spot and directional lights and its cameras; a camera selected") {
  // A triangle lit by a point light, a spot light and two directional lights; two cameras.
  const std::string gltf = R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
      {"type": "point", "color": [1, 1, 1], "intensity": 20, "range": 5},
      {"type": "spot", "color": [1, 1, 1], "intensity": 40, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.4}},
      {"type": "directional", "color": [1, 1, 1], "intensity": 2},
      {"type": "directional", "color": [1, 0.5, 0.5], "intensity": 3}]}},
    "cameras": [
      {"type": "perspective", "perspective": {"aspectRatio": 1.5, "yfov": 0.7, "znear": 0.05, "zfar": 40}},
      {"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1, "znear": 0.1, "zfar": 50}}],
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6]}],
    "nodes": [
      {"name": "triangle", "mesh": 0},
      {"name": "point", "translation": [0, 2, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
      {"name": "spot", "translation": [0, 3, 0], "rotation": [-0.70710678, 0, 0, 0.70710678],
       "extensions": {"KHR_lights_punctual": {"light": 1}}},
      {"name": "sun0", "extensions": {"KHR_lights_punctual": {"light": 2}}},
      {"name": "sun1", "rotation": [-0.70710678, 0, 0, 0.70710678], "extensions": {"KHR_lights_punctual": {"light": 3}}},
      {"name": "front", "translation": [0.5, 0.5, 3], "camera": 0},
      {"name": "flat", "translation": [0, 0, 5], "camera": 1}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "buffers": [{"byteLength": 36, "uri":
      "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}]
  })";
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  Reply loaded = api.put(s.path() + "/model?filename=lit.gltf&lights=model", gltf, s.token,
                         "application/octet-stream");
  REQUIRE(loaded.status == 200);
  const json& model = loaded.json.at("model");
  CHECK(model.at("lights") == json{{"point", 1}, {"spot", 1}, {"directional", 2}, {"directionalDropped", 0}});
  CHECK(loaded.json.at("lights").at("count") == 2);

  // The point and spot lights are the session's, glTF's falloff and cone; directional ones suns.
  const json lights = api.get(s.path() + "/lights", s.token).json.at("lights");
  REQUIRE(lights.size() == 2);
  CHECK(lights[0].at("type") == "point");
  CHECK(lights[0].at("attenuation") == "inverse-square");
  CHECK(lights[0].at("radius") == 5);
  CHECK(lights[1].at("type") == "spot");
  CHECK(lights[1].at("attenuation") == "inverse-square");
  CHECK(lights[1].at("intensity") == 40);
  CHECK(lights[1].at("innerConeAngle").get<double>() == doctest::Approx(0.1));
  CHECK(lights[1].at("outerConeAngle").get<double>() == doctest::Approx(0.4));
  CHECK(lights[1].at("direction")[1].get<double>() == doctest::Approx(-1.0));
  const json suns = loaded.json.at("settings").at("suns");
  REQUIRE(suns.size() == 2);
  CHECK(suns[0].at("intensity") == 3);  // brightest first
  CHECK(suns[0].at("direction")[1].get<double>() == doctest::Approx(-1.0));
  CHECK(suns[1].at("intensity") == 2);

  // Cameras listed with their node's placement; the perspective one becomes the camera.
  const json& cameras = model.at("cameras");
  REQUIRE(cameras.size() == 2);
  CHECK(cameras[0].at("index") == 0);
  CHECK(cameras[0].at("name") == "front");
  CHECK(cameras[0].at("type") == "perspective");
  CHECK(cameras[0].at("yfov").get<double>() == doctest::Approx(0.7).epsilon(1e-5));
  CHECK(cameras[0].at("aspectRatio").get<double>() == doctest::Approx(1.5));
  CHECK(cameras[0].at("zfar") == 40);
  CHECK(cameras[0].at("position") == json{0.5, 0.5, 3});
  CHECK(cameras[1].at("type") == "orthographic");
  Reply selected = api.post(s.path() + "/camera/select", R"({"modelCamera": 0})", s.token);
  REQUIRE(selected.status == 200);
  CHECK(selected.json.at("eye") == json{0.5, 0.5, 3});
  CHECK(selected.json.at("target")[2].get<double>() < 3.0);  // looking down -Z
  CHECK(selected.json.at("fovY").get<double>() == doctest::Approx(0.7 * 180.0 / 3.14159265358979).epsilon(1e-4));
  CHECK(selected.json.at("near").get<double>() == doctest::Approx(0.05));
  CHECK(selected.json.at("far") == 40);
  CHECK(api.get(s.path() + "/camera", s.token).json == selected.json);
  checkProblem(api.post(s.path() + "/camera/select", R"({"modelCamera": 1})", s.token), 400,
               "invalid-body", "select the orthographic camera", "/modelCamera");
  checkProblem(api.post(s.path() + "/camera/select", R"({"modelCamera": 2})", s.token), 400,
               "invalid-body", "select a camera the model lacks", "/modelCamera");

  // A frame from it renders (every light type on the GPU, validation on), and the snapshot keeps
  // the suns.
  Reply frame = api.get(s.path() + "/frame?width=64&height=48&format=raw", s.token);
  REQUIRE(frame.status == 200);
  CHECK(api.get(s.path() + "/snapshot", s.token).json.at("settings").at("suns") == suns);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

namespace {

// A 2 x 2 m floor (the model's size: its diagonal, 2.83 m) and one spot light of 1 cd without a
// range, `height` above the floor's centre, pointing down, its outer cone 0.15 rad.
std::string floorUnderSpot(float height) {
  myriad::test::GltfBuilder b;
  const int position = b.positions({-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1});
  const int normal = b.floats({0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0}, "VEC3", 3);
  const int index = b.accessor(std::vector<uint16_t>{0, 2, 1, 0, 3, 2}, "SCALAR", 5123, 6);
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(position) +
                     ",\"NORMAL\":" + std::to_string(normal) + "},\"indices\":" +
                     std::to_string(index) + "}]}");
  b.nodes.push_back(R"({"name": "floor", "mesh": 0})");
  b.nodes.push_back(R"({"name": "spot", "translation": [0, )" + std::to_string(height) +
                    R"(, 0], "rotation": [-0.70710678, 0, 0, 0.70710678],
                       "extensions": {"KHR_lights_punctual": {"light": 0}}})");
  b.sceneNodes = "[0, 1]";
  std::string gltf = b.json();
  const std::string lights = R"("extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "spot", "color": [1, 1, 1],
      "intensity": 1, "spot": {"innerConeAngle": 0.05, "outerConeAngle": 0.15}}]}},)";
  return gltf.insert(1, lights);
}

std::vector<float> rawFloats(const Reply& reply) {
  std::vector<float> values(reply.body.size() / sizeof(float));
  std::memcpy(values.data(), reply.body.data(), values.size() * sizeof(float));
  return values;
}

}  // namespace

TEST_CASE("api: ?lights=model lights a file with its own lights alone; a light without a range falls off as 1/d^2") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const float modelSize = std::sqrt(8.0f);
  REQUIRE(api.patch(s.path() + "/settings", R"({"markers": false})", s.token).status == 200);
  const std::string view = "/frame?width=96&height=72&format=raw&eye=0,3,3&look_at=0,0,0";
  // The centre pixel looks at the floor's centre, straight under the light in both placements:
  // the same directions, so its radiance goes with the illuminance alone.
  float centre[2] = {0.0f, 0.0f};
  const float heights[2] = {0.5f * modelSize, 2.0f * modelSize};
  for (int i = 0; i < 2; ++i) {
    Reply loaded = api.put(s.path() + "/model?filename=spot.gltf&lights=model",
                           floorUnderSpot(heights[i]), s.token, "application/octet-stream");
    REQUIRE(loaded.status == 200);
    CHECK(loaded.json.at("model").at("lights").at("spot") == 1);
    // The file's light alone: no sun, no sky, no ambient (glTF has none of them).
    const json settings = api.get(s.path() + "/settings", s.token).json;
    CHECK(settings.at("sun").at("intensity") == 0);
    CHECK(settings.at("environment").at("mode") == "none");
    CHECK(settings.at("ambient") == json{0, 0, 0});
    const json lights = api.get(s.path() + "/lights", s.token).json.at("lights");
    REQUIRE(lights.size() == 1);
    CHECK(lights[0].at("radius").get<double>() >= 8.0 * modelSize - 1e-3);
    Reply final = api.get(s.path() + view, s.token);
    Reply position = api.get(s.path() + view + "&target=position", s.token);
    REQUIRE(final.status == 200);
    REQUIRE(position.status == 200);
    const std::vector<float> radiance = rawFloats(final), where = rawFloats(position);
    REQUIRE(radiance.size() == size_t(96 * 72 * 3));
    REQUIRE(where.size() == radiance.size());
    centre[i] = radiance[(36 * 96 + 48) * 3 + 1];
    // Floor outside the cone (more than 1 m from the centre, the cone's reach being 0.86 m at
    // the larger height) is black: nothing else lights it.
    int outside = 0, lit = 0, nonFinite = 0;
    for (size_t p = 0; p < size_t(96 * 72); ++p) {
      for (int c = 0; c < 3; ++c) nonFinite += std::isfinite(radiance[p * 3 + c]) ? 0 : 1;
      const float x = where[p * 3], y = where[p * 3 + 1], z = where[p * 3 + 2];
      if (std::abs(y) > 1e-3f || std::abs(x) > 1.0f || std::abs(z) > 1.0f) continue;
      if (std::hypot(x, z) <= 1.0f) continue;
      ++outside;
      lit += radiance[p * 3] + radiance[p * 3 + 1] + radiance[p * 3 + 2] > 0.0f ? 1 : 0;
    }
    CHECK(nonFinite == 0);
    CHECK(outside > 100);
    CHECK(lit == 0);
  }
  // glTF's range-less light is 1/d^2: a quarter of the distance, 16 times the light, within 1%.
  REQUIRE(centre[1] > 0.0f);
  CHECK(centre[0] / centre[1] == doctest::Approx(16.0).epsilon(0.01));
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: ?sample= picks the stochastic shadows' sample: the same number the same bytes, another different") {
  ServerProcess server({"--lights", "64"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  REQUIRE(api.patch(s.path() + "/settings", R"({"shadows": {"local": "stochastic"}})", s.token)
              .status == 200);
  const std::string frame = s.path() + "/frame?width=64&height=48&format=raw";
  Reply first = api.get(frame + "&sample=7", s.token);
  Reply again = api.get(frame + "&sample=7", s.token);
  Reply other = api.get(frame + "&sample=8", s.token);
  Reply zero = api.get(frame, s.token);
  REQUIRE(first.status == 200);
  REQUIRE(again.status == 200);
  REQUIRE(other.status == 200);
  REQUIRE(zero.status == 200);
  CHECK(first.body == again.body);
  CHECK(first.body != other.body);
  CHECK(zero.body == api.get(frame + "&sample=0", s.token).body);  // 0 is the default
  for (const char* bad : {"-1", "4294967296", "1.5", "x"}) {
    checkProblem(api.get(frame + "&sample=" + bad, s.token), 400, "invalid-parameter", bad,
                 std::nullopt, std::nullopt, "sample");
  }
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: lights ask for shadows; maxShadowedLights is bounded; stats name the shadowed lights") {
  ServerProcess server({"--lights", "0"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string settings = s.path() + "/settings";
  // Outside 0..16: a 400 naming the member, settings unchanged.
  for (const char* bad : {R"({"shadows": {"maxShadowedLights": 17}})",
                          R"({"shadows": {"maxShadowedLights": -1}})",
                          R"({"shadows": {"maxShadowedLights": 2.5}})"}) {
    checkProblem(api.patch(settings, bad, s.token), 400, "invalid-body", bad,
                 std::string("/shadows/maxShadowedLights"));
  }
  Reply current = api.get(settings, s.token);
  REQUIRE(current.status == 200);
  CHECK(current.json["shadows"]["maxShadowedLights"] == 4);
  Reply patched = api.patch(settings, R"({"shadows": {"maxShadowedLights": 1}})", s.token);
  REQUIRE(patched.status == 200);
  CHECK(patched.json["shadows"]["maxShadowedLights"] == 1);
  // shadows.local: maps by default; a name of local_shadow_modes, or a 400 naming the member.
  CHECK(current.json["shadows"]["local"] == "maps");
  checkProblem(api.patch(settings, R"({"shadows": {"local": "raytraced"}})", s.token), 400,
               "invalid-body", "raytraced", std::string("/shadows/local"));
  Reply traced = api.patch(settings, R"({"shadows": {"local": "stochastic"}})", s.token);
  REQUIRE(traced.status == 200);
  CHECK(traced.json["shadows"]["local"] == "stochastic");
  CHECK(traced.json["shadows"]["maxShadowedLights"] == 1);
  REQUIRE(api.patch(settings, R"({"shadows": {"local": "maps"}})", s.token).status == 200);
  // shadows.cascades: 4 by default, 1 to 4, or a 400 naming the member.
  CHECK(current.json["shadows"]["cascades"] == 4);
  for (const char* bad : {R"({"shadows": {"cascades": 0}})", R"({"shadows": {"cascades": 5}})",
                          R"({"shadows": {"cascades": 2.5}})"}) {
    checkProblem(api.patch(settings, bad, s.token), 400, "invalid-body", bad,
                 std::string("/shadows/cascades"));
  }
  Reply cascaded = api.patch(settings, R"({"shadows": {"cascades": 2}})", s.token);
  REQUIRE(cascaded.status == 200);
  CHECK(cascaded.json["shadows"]["cascades"] == 2);
  // The shadow view, raw: the sun's shadow factor in [0, 1] and the cascade, 0 or 1 on a surface.
  Reply shadowView = api.get(s.path() + "/frame?target=shadow&format=raw&width=64&height=48", s.token);
  REQUIRE(shadowView.status == 200);
  CHECK(shadowView.header("X-Myriad-Channels") == "lit,cascade");
  REQUIRE(shadowView.body.size() == size_t(64) * 48 * 2 * sizeof(float));
  std::vector<float> values(shadowView.body.size() / sizeof(float));
  std::memcpy(values.data(), shadowView.body.data(), shadowView.body.size());
  size_t surface = 0, bad = 0;
  for (size_t i = 0; i < values.size(); i += 2) {
    if (values[i + 1] < 0.0f) continue;  // no surface
    ++surface;
    bad += (values[i] >= 0.0f && values[i] <= 1.0f && (values[i + 1] == 0.0f || values[i + 1] == 1.0f)) ? 0 : 1;
  }
  CHECK(surface > 0);
  CHECK(bad == 0);
  REQUIRE(api.patch(settings, R"({"shadows": {"cascades": 4}})", s.token).status == 200);

  // Three lights over the scene's centre, two asking; the brighter of those gets the one map.
  const json lights = {
      {"lights",
       {{{"position", {0.0, 2.0, 0.0}}, {"radius", 8.0}, {"color", {1.0, 1.0, 1.0}}, {"intensity", 2.0},
         {"falloff", 1.0}, {"castsShadows", true}},
        {{"position", {1.0, 2.0, 0.0}}, {"radius", 8.0}, {"color", {1.0, 1.0, 1.0}}, {"intensity", 5.0},
         {"falloff", 1.0}, {"castsShadows", true}, {"type", "spot"}},
        {{"position", {-1.0, 2.0, 0.0}}, {"radius", 8.0}, {"color", {1.0, 1.0, 1.0}}, {"intensity", 9.0},
         {"falloff", 1.0}}}}};
  Reply added = api.post(s.path() + "/lights", lights.dump(), s.token);
  REQUIRE(added.status == 201);
  const uint64_t dim = added.json["ids"][0], bright = added.json["ids"][1], plain = added.json["ids"][2];
  CHECK(api.get(s.path() + "/lights/" + std::to_string(plain), s.token).json["castsShadows"] == false);
  CHECK(api.get(s.path() + "/lights/" + std::to_string(bright), s.token).json["castsShadows"] == true);

  const std::string frame = s.path() + "/frame?width=96&height=64&format=png";
  REQUIRE(api.get(frame, s.token).status == 200);
  Reply stats = api.get(s.path() + "/stats", s.token);
  REQUIRE(stats.status == 200);
  INFO(stats.body);
  CHECK(stats.json["lightShadows"]["lights"] == json::array({bright}));
  CHECK(stats.json["lightShadows"]["requested"] == 2);
  CHECK(stats.json["lightShadows"]["dropped"] == 1);
  bool timed = false;
  for (const json& pass : stats.json["frame"]["passes"]) timed = timed || pass["name"] == "light-shadows";
  CHECK(timed);

  // The bright one stops asking: the other gets the map.
  REQUIRE(api.patch(s.path() + "/lights/" + std::to_string(bright), R"({"castsShadows": false})", s.token)
              .status == 200);
  REQUIRE(api.get(frame, s.token).status == 200);
  stats = api.get(s.path() + "/stats", s.token);
  CHECK(stats.json["lightShadows"]["lights"] == json::array({dim}));
  CHECK(stats.json["lightShadows"]["dropped"] == 0);
  // None allowed: every asking light is reported dropped, none shadowed.
  REQUIRE(api.patch(settings, R"({"shadows": {"maxShadowedLights": 0}})", s.token).status == 200);
  REQUIRE(api.get(frame, s.token).status == 200);
  stats = api.get(s.path() + "/stats", s.token);
  CHECK(stats.json["lightShadows"]["lights"] == json::array());
  CHECK(stats.json["lightShadows"]["dropped"] == 1);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: fog is off by default, PATCHed member by member, checked, kept by snapshots and timed") {
  ServerProcess server({"--lights", "0"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string settings = s.path() + "/settings";
  Reply current = api.get(settings, s.token);
  REQUIRE(current.status == 200);
  CHECK(current.json["fog"]["density"] == 0);
  CHECK(current.json["fog"]["color"] == json::array({0.5, 0.6, 0.7}));

  Reply patched = api.patch(settings, R"({"fog": {"density": 0.02, "color": [0.25, 0.5, 1]}})", s.token);
  REQUIRE(patched.status == 200);
  CHECK(patched.json["fog"]["density"] == 0.02);
  CHECK(patched.json["fog"]["color"] == json::array({0.25, 0.5, 1.0}));
  // One member keeps the other.
  patched = api.patch(settings, R"({"fog": {"density": 0.5}})", s.token);
  REQUIRE(patched.status == 200);
  CHECK(patched.json["fog"]["density"] == 0.5);
  CHECK(patched.json["fog"]["color"] == json::array({0.25, 0.5, 1.0}));
  CHECK(api.get(settings, s.token).json["fog"] == patched.json["fog"]);

  // Out of [0, 10], or not a number: a 400 naming the member, the settings unchanged. A bare NaN
  // is not JSON at all (refused while parsing, before any member is looked at).
  for (const char* bad : {R"({"fog": {"density": -0.01}})", R"({"fog": {"density": 11}})",
                          R"({"fog": {"density": "NaN"}})", R"({"fog": {"density": null}})"}) {
    checkProblem(api.patch(settings, bad, s.token), 400, "invalid-body", bad, std::string("/fog/density"));
  }
  checkProblem(api.patch(settings, R"({"fog": {"density": NaN}})", s.token), 400, "invalid-body",
               "NaN", std::string(""));
  checkProblem(api.patch(settings, R"({"fog": {"color": [0.5, -1, 0.5]}})", s.token), 400,
               "invalid-body", "negative colour", std::string("/fog/color/1"));
  CHECK(api.get(settings, s.token).json["fog"] == patched.json["fog"]);

  // A frame with fog runs the pass (Server-Timing names it); without, it does not.
  const std::string frame = s.path() + "/frame?width=64&height=48&format=png";
  Reply foggy = api.get(frame, s.token);
  REQUIRE(foggy.status == 200);
  CHECK(foggy.header("Server-Timing").find("fog;") != std::string::npos);

  // Snapshots keep it; one without it (from before fog) restores it off.
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json["settings"]["fog"] == patched.json["fog"]);
  TestSession copy = createSession(api);
  REQUIRE(api.put(copy.path() + "/snapshot", snapshot.body, copy.token).status == 200);
  CHECK(api.get(copy.path() + "/settings", copy.token).json["fog"] == patched.json["fog"]);
  json old = snapshot.json;
  old["settings"].erase("fog");
  REQUIRE(api.put(copy.path() + "/snapshot", old.dump(), copy.token).status == 200);
  CHECK(api.get(copy.path() + "/settings", copy.token).json["fog"]["density"] == 0);

  REQUIRE(api.patch(settings, R"({"fog": {"density": 0}})", s.token).status == 200);
  Reply clear = api.get(frame, s.token);
  REQUIRE(clear.status == 200);
  CHECK(clear.header("Server-Timing").find("fog;") == std::string::npos);
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("api: antialias taa and ssaa: the same bytes twice, the resolve timed, data views as none's") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string size = "&width=96&height=64";
  // The stateless frame (?antialias=) and a session's (its setting).
  const std::string stateless = "/v1/frame?format=png" + size;
  const std::string sessionFrame = s.path() + "/frame?format=png" + size;
  const std::string sessionDepth = s.path() + "/frame?format=raw&target=depth" + size;
  REQUIRE(api.patch(s.path() + "/settings", R"({"antialias": "none"})", s.token).status == 200);
  const Reply plain = api.get(stateless + "&antialias=none");
  const Reply sessionPlain = api.get(sessionFrame, s.token);
  const Reply depthNone = api.get(sessionDepth, s.token);
  REQUIRE(plain.status == 200);
  REQUIRE(sessionPlain.status == 200);
  REQUIRE(depthNone.status == 200);
  for (const std::string mode : {"taa", "ssaa"}) {
    CAPTURE(mode);
    const Reply a = api.get(stateless + "&antialias=" + mode);
    const Reply b = api.get(stateless + "&antialias=" + mode);
    REQUIRE(a.status == 200);
    REQUIRE(b.status == 200);
    CHECK(a.body == b.body);  // no state between frames: a still is the same bytes each time
    CHECK(a.body != plain.body);
    CHECK(a.header("Server-Timing").find("resolve-" + mode + ";") != std::string::npos);
    // As the session's setting; a data view is none's, byte for byte.
    const Reply patched = api.patch(s.path() + "/settings", json{{"antialias", mode}}.dump(), s.token);
    REQUIRE(patched.status == 200);
    CHECK(patched.json["antialias"] == mode);
    const Reply c = api.get(sessionFrame, s.token);
    REQUIRE(c.status == 200);
    CHECK(c.body == api.get(sessionFrame, s.token).body);
    CHECK(c.body != sessionPlain.body);
    const Reply depth = api.get(sessionDepth, s.token);
    REQUIRE(depth.status == 200);
    CHECK(depth.body == depthNone.body);
  }
  checkProblem(api.get("/v1/frame?antialias=msaa"), 400, "invalid-parameter", "an unknown mode",
               std::nullopt, std::nullopt, std::string("antialias"));
  checkProblem(api.patch(s.path() + "/settings", R"({"antialias": "msaa"})", s.token), 400,
               "invalid-body", "an unknown mode", std::string("/antialias"));
  CHECK(myriad::test::validationMessages(api) == 0);
  checkStopsCleanly(server);
}
