// CPU-only tests of the service layer: flags, frame queries, problem bodies, PNG round trips.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/png.h"
#include "scene/model_loader.h"
#include "service/frame_query.h"
#include "service/options.h"
#include "service/problem.h"
#include "service/startup.h"

using namespace myriad;
using service::FrameQueryError;
using service::Options;
using service::UsageError;

namespace {

Options parse(std::vector<std::string_view> args) {
  return service::parseOptions(args);
}

std::string usageErrorOf(std::vector<std::string_view> args) {
  try {
    service::parseOptions(args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

service::FrameDefaults defaults() {
  service::FrameDefaults d;
  d.camera.eye = {0.0f, 2.0f, 6.0f};
  d.camera.target = {0.0f, 0.0f, 0.0f};
  d.camera.farPlane = 20.0f;
  d.sceneBounds.extend({-5.0f, 0.0f, -5.0f});
  d.sceneBounds.extend({5.0f, 2.0f, 5.0f});
  d.maxResolution = 2048;
  return d;
}

render::FrameSettings query(std::multimap<std::string, std::string> params) {
  return service::parseFrameQuery(params, defaults());
}

struct QueryFailure {
  std::string parameter;
  std::string detail;
  bool unknown = false;
};

QueryFailure failureOf(std::multimap<std::string, std::string> params) {
  try {
    service::parseFrameQuery(params, defaults());
  } catch (const FrameQueryError& e) {
    return {e.parameter(), e.what(), e.unknownParameter()};
  }
  return {"<accepted>", "", false};
}

std::vector<uint8_t> gradient(uint32_t width, uint32_t height) {
  std::vector<uint8_t> rgba(size_t(width) * height * 4);
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      uint8_t* p = &rgba[(size_t(y) * width + x) * 4];
      p[0] = uint8_t(x * 255 / std::max(1u, width - 1));
      p[1] = uint8_t(y * 255 / std::max(1u, height - 1));
      p[2] = uint8_t((x * 7 + y * 13) & 0xff);
      p[3] = uint8_t(255 - (x + y) % 64);
    }
  }
  return rgba;
}

}  // namespace

TEST_CASE("options: defaults") {
  Options o = parse({});
  CHECK(o.host == "127.0.0.1");
  CHECK(o.port == 8080);
  CHECK(o.device.empty());
  CHECK_FALSE(o.validate);
  CHECK_FALSE(o.model.has_value());
  CHECK(o.lights == 256);
  CHECK(o.seed == 1);
  CHECK(o.maxResolution == 4096);
  CHECK(o.threads == 32);
  CHECK(o.maxQueuedFrames == 4);
  CHECK(o.maxSessions == 16);
  CHECK(o.maxLightsPerSession == 1000000);
  CHECK(o.maxUploadBytes == 64ull << 20);
  CHECK(o.maxBodyBytes == 1ull << 20);
  CHECK(o.maxStreams == 8);
  CHECK(o.maxStreamsPerSession == 4);
  CHECK(o.maxRequestsInFlight == 64);
  CHECK(o.sessionIdleSeconds == 600);
  CHECK_FALSE(o.modelsDir.has_value());
  CHECK_FALSE(o.apiKey.has_value());
  CHECK(o.corsOrigins.empty());
  // Every stream and waiting frame holds a worker; the rest must stay free for other requests.
  CHECK(o.threads > o.maxStreams + o.maxQueuedFrames + 8);
  CHECK_FALSE(o.help);
}

TEST_CASE("options: every flag, in both spellings") {
  Options o = parse({"--host", "0.0.0.0", "--port=0", "--device", "1", "--validate", "--model",
                     "/tmp/a.glb", "--lights=16", "--seed", "18446744073709551615",
                     "--max-resolution", "512", "--threads=3", "--max-queued-frames", "0",
                     "--technique", "tiled"});
  CHECK(o.host == "0.0.0.0");
  CHECK(o.port == 0);
  CHECK(o.device == "1");
  CHECK(o.validate);
  REQUIRE(o.model.has_value());
  CHECK(*o.model == "/tmp/a.glb");
  CHECK(o.lights == 16);
  CHECK(o.seed == 18446744073709551615ull);
  CHECK(o.maxResolution == 512);
  CHECK(o.threads == 3);
  CHECK(o.maxQueuedFrames == 0);
  CHECK(o.technique == render::Technique::Tiled);
  CHECK(parse({}).technique == render::Technique::Clustered);
  CHECK(parse({"--technique=volumes"}).technique == render::Technique::Volumes);
  CHECK(parse({}).maxFrameSeconds == 120);
  CHECK(parse({"--max-frame-seconds", "0"}).maxFrameSeconds == 0);
  CHECK(parse({"--max-frame-seconds=40"}).maxFrameSeconds == 40);
  CHECK(parse({}).framesInFlight == 2);
  CHECK(parse({"--frames-in-flight", "1"}).framesInFlight == 1);
  CHECK(parse({"--frames-in-flight=4"}).framesInFlight == 4);
  CHECK_FALSE(parse({}).overlapFrames);
  CHECK(parse({"--overlap-frames"}).overlapFrames);
  CHECK(parse({}).gbuffer == render::GBufferPath::Auto);
  CHECK(parse({"--gbuffer", "raster"}).gbuffer == render::GBufferPath::Raster);
  CHECK(parse({"--gbuffer", "compute"}).gbuffer == render::GBufferPath::Compute);
  CHECK(parse({"--gbuffer=auto"}).gbuffer == render::GBufferPath::Auto);
  CHECK(parse({"--help"}).help);
  CHECK(parse({"-h"}).help);
  CHECK(parse({"--port", "1", "--port", "2"}).port == 2);  // last one wins
  CHECK(parse({"--device", "llvmpipe"}).device == "llvmpipe");
}

TEST_CASE("options: session limits, library, key and CORS") {
  Options o = parse({"--max-sessions", "3", "--max-lights=10", "--max-upload-bytes", "4096",
                     "--max-body-bytes", "2048", "--max-streams", "2", "--max-requests", "5",
                     "--session-idle-seconds", "1", "--models", "/srv/models", "--api-key",
                     "secret-key", "--cors-origin", "http://a.test", "--cors-origin", "*"});
  CHECK(o.maxSessions == 3);
  CHECK(o.maxLightsPerSession == 10);
  CHECK(o.maxUploadBytes == 4096);
  CHECK(o.maxBodyBytes == 2048);
  CHECK(o.maxStreams == 2);
  CHECK(o.maxStreamsPerSession == 1);  // half of --max-streams, rounded up
  CHECK(parse({"--max-streams", "5"}).maxStreamsPerSession == 3);
  CHECK(parse({"--max-streams", "0"}).maxStreamsPerSession == 1);
  CHECK(parse({"--max-streams-per-session", "6", "--max-streams", "2"}).maxStreamsPerSession == 6);
  CHECK(usageErrorOf({"--max-streams-per-session", "0"}).find("--max-streams-per-session") !=
        std::string::npos);
  CHECK(o.maxRequestsInFlight == 5);
  CHECK(o.sessionIdleSeconds == 1);
  CHECK(o.modelsDir == std::optional<std::string>("/srv/models"));
  CHECK(o.apiKey == std::optional<std::string>("secret-key"));
  CHECK(o.corsOrigins == std::vector<std::string>{"http://a.test", "*"});
  CHECK(usageErrorOf({"--max-sessions", "0"}).find("--max-sessions") != std::string::npos);
  CHECK(usageErrorOf({"--session-idle-seconds", "0"}).find("--session-idle-seconds") !=
        std::string::npos);
  CHECK(usageErrorOf({"--api-key", "short"}).find("--api-key") != std::string::npos);
  CHECK(usageErrorOf({"--models="}).find("--models") != std::string::npos);
}

TEST_CASE("options: bad flags and values are one sentence naming the flag") {
  struct Case {
    std::vector<std::string_view> args;
    std::string mention;
  };
  const std::vector<Case> cases = {
      {{"--bogus"}, "--bogus"},
      {{"--bogus=1"}, "--bogus"},
      {{"stray"}, "stray"},
      {{"--port"}, "--port"},
      {{"--port", "65536"}, "--port"},
      {{"--port", "-1"}, "--port"},
      {{"--port", "80x"}, "--port"},
      {{"--port", ""}, "--port"},
      {{"--port="}, "--port"},
      {{"--lights", "2000000"}, "--lights"},
      {{"--lights", "1.5"}, "--lights"},
      {{"--technique", "deferred"}, "--technique"},
      {{"--seed", "-3"}, "--seed"},
      {{"--seed", "18446744073709551616"}, "--seed"},
      {{"--max-resolution", "0"}, "--max-resolution"},
      {{"--threads", "0"}, "--threads"},
      {{"--max-queued-frames", "many"}, "--max-queued-frames"},
      {{"--frames-in-flight", "0"}, "--frames-in-flight"},
      {{"--gbuffer", "visibility"}, "--gbuffer"},
      {{"--frames-in-flight", "5"}, "--frames-in-flight"},
      {{"--overlap-frames=yes"}, "--overlap-frames"},
      {{"--model", "--validate"}, "--model"},
      {{"--model="}, "--model"},
      {{"--host="}, "--host"},
      {{"--device", ""}, "--device"},
      {{"--validate=yes"}, "--validate"},
  };
  for (const Case& c : cases) {
    std::string error = usageErrorOf(c.args);
    INFO("args: ", c.args.front(), c.args.size() > 1 ? c.args[1] : "");
    CHECK_FALSE(error.empty());
    CHECK(error.find(c.mention) != std::string::npos);
    CHECK(error.back() == '.');
    CHECK(error.find('\n') == std::string::npos);
  }
}

TEST_CASE("options: --tune sets the renderer's knobs, repeatably, and refuses what it does not know") {
  // render/tuning.h: one interface for myriad-server and the bench binaries (issue 37).
  CHECK(parse({}).tuning == render::Tuning{});
  const Options o = parse({"--tune", "assign=atomic", "--tune=shade=pixel", "--tune", "point-test=2",
                           "--tune", "cluster-tile=32", "--tune", "shade-variant=0x3",
                           "--tune", "assign-steps=on", "--tune", "mark-in-gbuffer=off",
                           "--tune", "pipeline-stats=1", "--tune", "assign-pair-slots=4"});
  CHECK(o.tuning.assign == render::AssignPath::PerPair);
  CHECK(o.tuning.shade == render::ShadePass::Pixel);
  CHECK(o.tuning.pointTest == 2u);
  CHECK(o.tuning.clusterTile == 32);
  CHECK(o.tuning.shadeVariant == 3);
  CHECK(o.tuning.assignSteps);
  CHECK_FALSE(o.tuning.markInGBuffer);
  CHECK(o.tuning.pipelineStatistics);
  CHECK(o.tuning.assignPairSlots == 4u);
  CHECK(parse({"--tune", "cluster-slices=48", "--tune", "cluster-slices=64"}).tuning.clusterSlices == 64);
  struct Case {
    std::string_view tune;
    std::string mention;
  };
  const std::vector<Case> cases = {
      {"bogus=1", "unknown key \"bogus\""},
      {"cluster-tile=48", "cluster-tile expects 16, 32 or 64, not \"48\""},
      {"cluster-slices=8", "cluster-slices expects a number from 16 to 128"},
      {"assign=sometimes", "assign expects auto, atomic or binned"},
      {"assign-group-size=300", "assign-group-size"},
      {"point-test=3", "point-test"},
      {"assign-steps=maybe", "assign-steps expects on or off"},
      {"shade=volumes", "shade expects auto, pixel, subgroup or whole"},
      {"shade-variant=x", "shade-variant"},
      {"assign-bins=", "assign-bins"},
      {"cluster-tile", "key=value"},
      {"=32", "key=value"},
  };
  for (const Case& c : cases) {
    const std::string error = usageErrorOf({"--tune", c.tune});
    INFO("--tune ", c.tune, ": ", error);
    CHECK(error.find(c.mention) != std::string::npos);
    CHECK(error.back() == '.');
    CHECK(error.find('\n') == std::string::npos);
  }
  CHECK(usageErrorOf({"--tune"}).find("--tune") != std::string::npos);
  CHECK(service::usage().find("assign-steps=on|off") != std::string::npos);
}

TEST_CASE("options: usage lists every flag") {
  std::string text = service::usage();
  for (const char* flag :
       {"--host", "--port", "--device", "--validate", "--model", "--lights", "--seed",
        "--max-resolution", "--threads", "--max-queued-frames", "--max-frame-seconds",
        "--frames-in-flight",
        "--overlap-frames", "--max-sessions", "--max-lights",
        "--max-upload-bytes", "--max-body-bytes", "--max-streams", "--max-streams-per-session",
        "--max-requests", "--session-idle-seconds", "--models", "--api-key", "--cors-origin", "--tune",
        "--help"}) {
    CHECK(text.find(flag) != std::string::npos);
  }
}

TEST_CASE("frame query: defaults come from the scene and the size limit") {
  render::FrameSettings s = query({});
  CHECK(s.width == 1280);
  CHECK(s.height == 720);
  CHECK(s.target == render::Target::Final);
  CHECK(s.markers);
  CHECK(s.exposure == 1.0f);
  CHECK(s.camera.eye == defaults().camera.eye);
  CHECK(s.camera.target == defaults().camera.target);
  CHECK(s.camera.farPlane == defaults().camera.farPlane);

  service::FrameDefaults small = defaults();
  small.maxResolution = 640;
  render::FrameSettings shrunk = service::parseFrameQuery({}, small);
  CHECK(shrunk.width == 640);
  CHECK(shrunk.height == 360);
}

TEST_CASE("frame query: every parameter applies") {
  render::FrameSettings s = query({{"target", "light-volumes"},
                                   {"width", "2048"},
                                   {"height", "1"},
                                   {"eye", "1,2.5,-3e1"},
                                   {"look_at", "0,0.5,0"},
                                   {"fov", "90"},
                                   {"markers", "false"},
                                   {"exposure", "2.5"},
                                   {"technique", "volumes"}});
  CHECK(s.target == render::Target::LightVolumes);
  CHECK(s.technique == render::Technique::Volumes);
  CHECK(s.width == 2048);
  CHECK(s.height == 1);
  CHECK(s.camera.eye == glm::vec3(1.0f, 2.5f, -30.0f));
  CHECK(s.camera.target == glm::vec3(0.0f, 0.5f, 0.0f));
  CHECK(s.camera.fovYDegrees == 90.0f);
  CHECK_FALSE(s.markers);
  CHECK(s.exposure == 2.5f);
  // The eye moved 30 m out: the far plane must still reach past the scene.
  CHECK(s.camera.farPlane > glm::length(s.camera.eye) + 5.0f);

  for (std::string_view name : render::kTargetNames) {
    CHECK(render::targetName(query({{"target", std::string(name)}}).target) == name);
  }
  CHECK(query({{"markers", "1"}}).markers);
  CHECK_FALSE(query({{"markers", "0"}}).markers);
  CHECK(query({{"markers", "true"}}).markers);
}

TEST_CASE("frame query: looking straight down keeps a usable up vector") {
  render::FrameSettings s = query({{"eye", "0,10,0"}, {"look_at", "0,0,0"}});
  glm::vec3 forward = glm::normalize(s.camera.target - s.camera.eye);
  CHECK(glm::length(glm::cross(forward, glm::normalize(s.camera.up))) > 0.5f);
}

TEST_CASE("frame query: every bad value names its parameter") {
  struct Case {
    std::multimap<std::string, std::string> params;
    std::string parameter;
  };
  const std::vector<Case> cases = {
      {{{"target", "bogus"}}, "target"},
      {{{"target", ""}}, "target"},
      {{{"target", "FINAL"}}, "target"},
      {{{"width", ""}}, "width"},
      {{{"width", "abc"}}, "width"},
      {{{"width", "nan"}}, "width"},
      {{{"width", "NaN"}}, "width"},
      {{{"width", "inf"}}, "width"},
      {{{"width", "-5"}}, "width"},
      {{{"width", "0"}}, "width"},
      {{{"width", "12.5"}}, "width"},
      {{{"width", "1e3"}}, "width"},
      {{{"width", " 64"}}, "width"},
      {{{"width", "64 "}}, "width"},
      {{{"width", "+64"}}, "width"},
      {{{"width", "2049"}}, "width"},
      {{{"width", "99999999999999999999999"}}, "width"},
      {{{"height", "0"}}, "height"},
      {{{"height", "-1"}}, "height"},
      {{{"height", "4097"}}, "height"},
      {{{"height", "1.0"}}, "height"},
      {{{"eye", "1,2"}}, "eye"},
      {{{"eye", "1,2,3,4"}}, "eye"},
      {{{"eye", "1,2,"}}, "eye"},
      {{{"eye", ",1,2"}}, "eye"},
      {{{"eye", "a,b,c"}}, "eye"},
      {{{"eye", "1,nan,3"}}, "eye"},
      {{{"eye", "1,inf,3"}}, "eye"},
      {{{"eye", "1;2;3"}}, "eye"},
      {{{"eye", ""}}, "eye"},
      {{{"eye", "1e7,0,0"}}, "eye"},
      {{{"look_at", "0,0"}}, "look_at"},
      {{{"look_at", "0,0,x"}}, "look_at"},
      {{{"eye", "1,1,1"}, {"look_at", "1,1,1"}}, "look_at"},
      {{{"eye", "0,0,0"}}, "eye"},          // equals the default look-at point
      {{{"look_at", "0,2,6"}}, "look_at"},  // equals the default eye
      {{{"fov", "0"}}, "fov"},
      {{{"fov", "180"}}, "fov"},
      {{{"fov", "-10"}}, "fov"},
      {{{"fov", "nan"}}, "fov"},
      {{{"fov", "wide"}}, "fov"},
      {{{"markers", "yes"}}, "markers"},
      {{{"markers", ""}}, "markers"},
      {{{"markers", "TRUE"}}, "markers"},
      {{{"exposure", "0"}}, "exposure"},
      {{{"exposure", "-1"}}, "exposure"},
      {{{"exposure", "inf"}}, "exposure"},
      {{{"exposure", "bright"}}, "exposure"},
      {{{"technique", "deferred"}}, "technique"},
      {{{"technique", ""}}, "technique"},
      {{{"zoom", "2"}}, "zoom"},
      {{{"Width", "64"}}, "Width"},
      {{{"width", "64"}, {"width", "65"}}, "width"},
  };
  for (const Case& c : cases) {
    QueryFailure failure = failureOf(c.params);
    INFO("query: ", c.params.begin()->first, "=", c.params.begin()->second);
    CHECK(failure.parameter == c.parameter);
    CHECK(failure.detail.find(c.parameter) != std::string::npos);
    CHECK(failure.unknown == (c.parameter == "zoom" || c.parameter == "Width"));
  }
}

TEST_CASE("frame query: the size error states the limit") {
  QueryFailure failure = failureOf({{"width", "5000"}});
  CHECK(failure.detail.find("2048") != std::string::npos);
  // Unknown parameters are reported before bad values, so a typo is not hidden by another error.
  CHECK(failureOf({{"width", "0"}, {"colour", "red"}}).parameter == "colour");
}

TEST_CASE("frame query: client text in a detail is bounded") {
  std::string huge(10000, 'x');
  QueryFailure failure = failureOf({{"target", huge}});
  CHECK(failure.parameter == "target");
  CHECK(failure.detail.size() < 400);
}

TEST_CASE("server timing: one metric per pass plus encode") {
  std::string header = service::formatServerTiming(
      {{"gbuffer", 1.2345}, {"sun", 0.5}, {"bad name,x", 2.0}, {"nan", std::nan("")}}, 3.25);
  CHECK(header ==
        "gbuffer;dur=1.234, sun;dur=0.500, bad-name-x;dur=2.000, nan;dur=0.000, "
        "encode;dur=3.250");
  CHECK(service::formatServerTiming({}, 1.0) == "encode;dur=1.000");
  CHECK(service::formatServerTiming({{"gbuffer", 1.0}}, 2.0, nullptr, 0.125) ==
        "gbuffer;dur=1.000, encode;dur=2.000, queue;dur=0.125");
}

TEST_CASE("problem: RFC 9457 members, and the parameter only when there is one") {
  service::Problem p = service::invalidParameter("width", "width must be positive.");
  nlohmann::json body = nlohmann::json::parse(service::toBody(p));
  CHECK(body["type"] == "https://myriad.dev/problems/invalid-parameter");
  CHECK(body["title"] == "Invalid query parameter");
  CHECK(body["status"] == 400);
  CHECK(body["detail"] == "width must be positive.");
  CHECK(body["parameter"] == "width");

  nlohmann::json notFound = service::toJson(service::notFound("/nope"));
  CHECK(notFound["status"] == 404);
  CHECK(notFound["type"] == "https://myriad.dev/problems/not-found");
  CHECK_FALSE(notFound.contains("parameter"));
  CHECK(notFound["detail"].get<std::string>().find("/nope") != std::string::npos);

  nlohmann::json notAllowed =
      service::toJson(service::methodNotAllowed("POST", "/v1/frame", "GET, HEAD"));
  CHECK(notAllowed["status"] == 405);
  CHECK(notAllowed["detail"].get<std::string>().find("POST") != std::string::npos);

  CHECK(service::toJson(service::unknownParameter("zoom", "no"))["type"] ==
        "https://myriad.dev/problems/unknown-parameter");
  CHECK(service::toJson(service::serverBusy("full"))["status"] == 503);
  CHECK(service::toJson(service::renderFailed("lost"))["status"] == 500);
}

TEST_CASE("problem: invalid UTF-8 from a client does not break the body") {
  std::string parameter = "bad\xff\xfe";
  std::string body = service::toBody(service::unknownParameter(parameter, "Unknown " + parameter));
  nlohmann::json parsed = nlohmann::json::parse(body);  // throws if the body were not UTF-8
  CHECK(parsed["status"] == 400);
}

TEST_CASE("png: round trip of odd sizes keeps every byte") {
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{1, 1}, {3, 5}, {160, 120}, {257, 31}}) {
    std::vector<uint8_t> rgba = gradient(w, h);
    std::vector<uint8_t> png = encode::encodePng(w, h, rgba);
    REQUIRE(png.size() > 8);
    CHECK(png[0] == 0x89);
    CHECK(png[1] == 'P');
    encode::DecodedImage decoded = encode::decodePng(png);
    CHECK(decoded.width == w);
    CHECK(decoded.height == h);
    CHECK(decoded.rgba == rgba);
  }
}

TEST_CASE("png: rendered-like content compresses") {
  std::vector<uint8_t> rgba = gradient(640, 480);
  std::vector<uint8_t> png = encode::encodePng(640, 480, rgba);
  CHECK(png.size() < rgba.size() / 2);
}

TEST_CASE("png: bad input is rejected, not encoded or crashed on") {
  std::vector<uint8_t> rgba(16);
  CHECK_THROWS_AS(encode::encodePng(2, 3, rgba), std::invalid_argument);
  CHECK_THROWS_AS(encode::encodePng(0, 4, {}), std::invalid_argument);
  CHECK_THROWS_AS(encode::encodePng(4, 0, {}), std::invalid_argument);

  CHECK_THROWS_AS(encode::decodePng({}), encode::PngError);
  std::vector<uint8_t> text = {'n', 'o', 't', ' ', 'a', ' ', 'p', 'n', 'g'};
  CHECK_THROWS_AS(encode::decodePng(text), encode::PngError);
  std::vector<uint8_t> png = encode::encodePng(64, 64, gradient(64, 64));
  png.resize(png.size() / 2);  // truncated mid-IDAT
  CHECK_THROWS_AS(encode::decodePng(png), encode::PngError);
}

TEST_CASE("startup: URLs and device lines") {
  CHECK(service::serverUrl("127.0.0.1", 8080) == "http://127.0.0.1:8080");
  CHECK(service::serverUrl("::1", 80) == "http://[::1]:80");
  render::DeviceSummary d;
  d.name = "llvmpipe";
  d.type = "cpu";
  d.driverName = "llvmpipe";
  d.driverInfo = "Mesa 22.3.6";
  d.apiVersion = "1.3.230";
  std::string line = service::describeDevice(d);
  for (const char* part : {"llvmpipe", "cpu", "Mesa 22.3.6", "1.3.230"}) {
    CHECK(line.find(part) != std::string::npos);
  }
}

TEST_CASE("startup: the scene gets the requested lights, around a model") {
  Options o;
  o.lights = 5;
  CHECK(service::buildScene(o).lights.size() == 5);

  o.model = "/usr/share/assimp/models/OBJ/box.obj";
  o.lights = 7;
  scene::Scene model = service::buildScene(o);
  REQUIRE(model.lights.size() == 7);
  scene::Bounds bounds = model.bounds();
  // Around the model: inside its bounds grown by a fraction of the diagonal.
  const glm::vec3 margin(0.2f * glm::length(bounds.size()));
  for (const scene::PointLight& light : model.lights) {
    CHECK(glm::all(glm::greaterThanEqual(light.position, bounds.min - margin)));
    CHECK(glm::all(glm::lessThanEqual(light.position, bounds.max + margin)));
    CHECK(light.radius > 0.0f);
    CHECK(light.radius < glm::length(bounds.size()));
  }

  o.model = "/nonexistent/model.obj";
  CHECK_THROWS_AS(service::buildScene(o), scene::ModelLoadError);
}
