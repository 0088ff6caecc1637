// GET .../frame?target=motion through the real server (validation on): a still camera gives no
// motion, a camera moved between two frames gives the move's motion in the next frame only, the
// raw answer is two float32 channels, the picture a PNG, and motion among several targets a 400.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "api_client.h"
#include "server_process.h"

using myriad::test::ApiClient;
using myriad::test::createSession;
using myriad::test::ServerProcess;
using myriad::test::TestSession;

namespace {

// The largest |value| of a raw float32 body.
float largest(const std::string& body) {
  std::vector<float> values(body.size() / 4);
  std::memcpy(values.data(), body.data(), values.size() * 4);
  float most = 0.0f;
  for (float v : values) most = std::max(most, std::abs(v));
  return most;
}

}  // namespace

TEST_CASE("motion api: the previous frame's camera, raw dx,dy, a picture, and never among several targets") {
  ServerProcess server({"--lights", "4"});
  ApiClient api(server);
  const TestSession s = createSession(api);
  const std::string raw = s.path() + "/frame?target=motion&format=raw&width=64&height=48";

  const auto still = api.get(raw, s.token);
  REQUIRE(still.status == 200);
  CHECK(still.header("X-Myriad-Channels") == "dx,dy");
  CHECK(still.body.size() == size_t(64) * 48 * 2 * 4);
  CHECK(largest(still.body) < 1e-2f);  // nothing moved

  REQUIRE(api.patch(s.path() + "/camera", R"({"eye":[3.2,3.9,7.6]})", s.token).status == 200);
  const auto moved = api.get(raw, s.token);
  REQUIRE(moved.status == 200);
  CHECK(largest(moved.body) > 1.0f);  // the orbit, from the previous frame's camera
  const auto after = api.get(raw, s.token);
  CHECK(largest(after.body) < 1e-2f);  // the camera stayed: no motion
  // ?time= is the same bytes on every call.
  const auto t1 = api.get(raw + "&time=0.5", s.token);
  const auto t2 = api.get(raw + "&time=0.5", s.token);
  CHECK(t1.status == 200);
  CHECK(t1.body == t2.body);

  const auto picture = api.get(s.path() + "/frame?target=motion&width=64&height=48", s.token);
  CHECK(picture.status == 200);
  CHECK(picture.header("Content-Type") == "image/png");

  const auto several = api.get(s.path() + "/frame?target=motion,depth&format=npz&width=64&height=48", s.token);
  CHECK(several.status == 400);
  CHECK(several.body.find("motion is drawn by its own pass") != std::string::npos);
  CHECK(myriad::test::validationMessages(api) == 0);
}
