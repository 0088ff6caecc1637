// The environment light over the API against the real server (validation on): settings'
// environment member, a session with a loaded model starting under the sky, and PUT
// .../environment with a Radiance .hdr generated here (valid, truncated, a bad header, huge
// dimensions in the header, not a Radiance file at all): 200 and a changed image, or a 422 naming
// the problem with the server healthy after each.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "server_process.h"

using myriad::test::ApiClient;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using nlohmann::json;

namespace {

// One RGBE pixel (Ward's shared exponent) of linear radiance (r, g, b).
void putRgbe(std::string& out, float r, float g, float b) {
  const float top = std::max(r, std::max(g, b));
  if (top < 1e-32f) {
    out.append(4, '\0');
    return;
  }
  int exponent = 0;
  const float mantissa = std::frexp(top, &exponent) * 256.0f / top;
  out += char(uint8_t(r * mantissa));
  out += char(uint8_t(g * mantissa));
  out += char(uint8_t(b * mantissa));
  out += char(uint8_t(exponent + 128));
}

// A small uncompressed (flat) Radiance file, width x height: a warm bright band above a dark blue
// floor, so a metallic sphere reflects something unlike the sky.
std::string makeHdr(int width, int height) {
  std::string file = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(height) +
                     " +X " + std::to_string(width) + "\n";
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (y < height / 2) {
        putRgbe(file, 2.0f + float(x) / float(width), 0.6f, 0.1f);
      } else {
        putRgbe(file, 0.02f, 0.05f, 0.3f);
      }
    }
  }
  return file;
}

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

int differingBytes(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return int(std::max(a.size(), b.size()));
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i] ? 1 : 0;
  return n;
}

}  // namespace

TEST_CASE("api: the environment light: sky for a loaded model, .hdr upload, broken .hdr is 422") {
  // A library with one .hdr (PUT .../environment {"source": "library:sky.hdr"}).
  std::string pattern = "/tmp/myriad-env-models-XXXXXX";
  REQUIRE(mkdtemp(pattern.data()) != nullptr);
  const std::filesystem::path models = pattern;
  std::ofstream(models / "sky.hdr", std::ios::binary) << makeHdr(32, 16);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() { std::filesystem::remove_all(dir); }
  } cleanup{models};
  ServerProcess server({"--lights", "0", "--models", models.string()});
  requireListening(server);
  ApiClient api(server);

  // The built-in scene keeps its constant ambient (mode none).
  TestSession s = createSession(api);
  Reply settings = api.get(s.path() + "/settings", s.token);
  REQUIRE(settings.status == 200);
  CHECK(settings.json["environment"] ==
        json{{"mode", "none"}, {"intensity", 1.0}, {"rotation", 0.0}, {"background", false}});

  // A loaded model starts under the sky.
  const std::string box = [] {
    std::ifstream in("/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
                     std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  REQUIRE(!box.empty());
  Reply loaded = api.put(s.path() + "/model?filename=box.glb", box, s.token,
                         "application/octet-stream");
  REQUIRE(loaded.status == 200);
  CHECK(loaded.json["settings"]["environment"]["mode"] == "sky");

  // Sun off: the sky alone lights the model; mode none (ambient 0) leaves it black.
  const std::string frame = s.path() + "/frame?width=96&height=64&format=png";
  REQUIRE(api.patch(s.path() + "/settings",
                    R"({"sun": {"intensity": 0}, "ambient": [0, 0, 0], "markers": false})", s.token)
              .status == 200);
  const std::string sky = api.get(frame, s.token).body;
  REQUIRE(api.patch(s.path() + "/settings", R"({"environment": {"mode": "none"}})", s.token).status == 200);
  const std::string none = api.get(frame, s.token).body;
  CHECK(differingBytes(sky, none) > 0);

  // hdr needs an image first: 400 naming the member, nothing changed.
  checkProblem(api.patch(s.path() + "/settings", R"({"environment": {"mode": "hdr"}})", s.token),
               400, "invalid-body", "hdr without an image", "/environment/mode");
  CHECK(api.get(s.path() + "/settings", s.token).json["environment"]["mode"] == "none");

  // A valid .hdr: 200, mode hdr, a different picture; rotation and background change it again.
  Reply put = api.put(s.path() + "/environment?filename=test.hdr", makeHdr(16, 8), s.token,
                      "image/vnd.radiance");
  INFO(put.body);
  REQUIRE(put.status == 200);
  CHECK(put.json["environment"]["mode"] == "hdr");
  const std::string hdr = api.get(frame, s.token).body;
  CHECK(differingBytes(hdr, sky) > 0);
  CHECK(differingBytes(hdr, none) > 0);
  REQUIRE(api.patch(s.path() + "/settings", R"({"environment": {"rotation": 1.5}})", s.token).status == 200);
  const std::string rotated = api.get(frame, s.token).body;
  CHECK(differingBytes(rotated, hdr) > 0);
  REQUIRE(api.patch(s.path() + "/settings", R"({"environment": {"background": true}})", s.token).status == 200);
  CHECK(differingBytes(api.get(frame, s.token).body, rotated) > 0);
  // application/octet-stream works too.
  CHECK(api.put(s.path() + "/environment", makeHdr(32, 16), s.token, "application/octet-stream")
            .status == 200);

  // Broken .hdr files: each a 422 naming the problem; the server stays healthy and the session
  // keeps its environment.
  const std::string valid = makeHdr(16, 8);
  struct Broken {
    const char* what;
    std::string bytes;
    const char* detail;
  };
  const Broken broken[] = {
      {"truncated", valid.substr(0, valid.size() - 100), "truncated"},
      {"bad header", "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 8 +X 16\n" + std::string(512, '\x40'),
       "bad Radiance header"},
      {"no resolution line", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Q 8 -Z 16\n" + std::string(512, '\x40'),
       "bad Radiance header"},
      {"huge dimensions", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 200000\n" +
                              std::string(64, '\x40'),
       "over the limit"},
      {"not a Radiance file", "P6\n16 8\n255\n" + std::string(384, '\x7f'), "not a Radiance .hdr"},
      {"empty", "", "empty"},
      // A run-length scanline whose first run has length 0 (stb_image alone would loop forever).
      {"zero-length run", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 16\n" +
                              std::string("\x02\x02\x00\x10\x00", 5) + std::string(200, '\x01'),
       "run of length 0"},
  };
  for (const Broken& b : broken) {
    Reply reply = api.put(s.path() + "/environment", b.bytes, s.token, "image/vnd.radiance");
    checkProblem(reply, 422, "environment-rejected", b.what);
    CHECK_MESSAGE(reply.json.value("detail", "").find(b.detail) != std::string::npos,
                  b.what << ": " << reply.json.value("detail", ""));
    CHECK(api.get("/v1/health").status == 200);
  }
  checkProblem(api.put(s.path() + "/environment", valid, s.token, "text/plain"), 415,
               "unsupported-media-type", "text/plain");
  for (const char* name : {"library:../sky.hdr", "library:missing.hdr", "library:sky.glb",
                           "builtin:default"}) {
    checkProblem(api.put(s.path() + "/environment", json{{"source", name}}.dump(), s.token), 404,
                 "not-found", name);
  }
  Reply after = api.get(s.path() + "/settings", s.token);
  CHECK(after.json["environment"]["mode"] == "hdr");
  CHECK(api.get(frame, s.token).status == 200);

  // A snapshot carries the environment settings; restored where no .hdr was uploaded, mode hdr
  // is refused naming the member (the image is the session's, not the snapshot's).
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json["settings"]["environment"]["mode"] == "hdr");
  TestSession other = createSession(api);
  checkProblem(api.put(other.path() + "/snapshot", snapshot.json.dump(), other.token), 400,
               "invalid-body", "snapshot with hdr", "/settings/environment/mode");

  // A library image travels with a snapshot by its source: a new session gets it back.
  TestSession library = createSession(api);
  Reply fromLibrary =
      api.put(library.path() + "/environment", R"({"source": "library:sky.hdr"})", library.token);
  REQUIRE(fromLibrary.status == 200);
  CHECK(fromLibrary.json["environment"]["mode"] == "hdr");
  CHECK(fromLibrary.json["environment"]["source"] == "library:sky.hdr");
  const std::string libraryFrame = api.get(library.path() + "/frame?width=96&height=64&format=png", library.token).body;
  Reply librarySnapshot = api.get(library.path() + "/snapshot", library.token);
  REQUIRE(librarySnapshot.status == 200);
  Reply restored = api.post("/v1/sessions", json{{"snapshot", librarySnapshot.json}}.dump());
  INFO(restored.body);
  REQUIRE(restored.status == 201);
  CHECK(restored.json["session"]["settings"]["environment"]["source"] == "library:sky.hdr");
  const std::string restoredPath = "/v1/sessions/" + restored.json["id"].get<std::string>();
  const std::string restoredToken = restored.json["token"].get<std::string>();
  CHECK(differingBytes(api.get(restoredPath + "/frame?width=96&height=64&format=png", restoredToken).body,
                       libraryFrame) == 0);
  CHECK(myriad::test::validationMessages(api) == 0);
}
