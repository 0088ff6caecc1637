// The motion target (render/motion.h) on lavapipe with validation on: frame t warped by frame
// t + 1/30's motion vectors reproduces frame t + 1/30 on the surfaces visible in both, for a moving
// camera, a moving object and a bending skin. What is compared is the raw `uv` target: a surface
// point keeps its uv whatever moves, and uv is smooth, so a warp's error converts to pixels
// through the uv's own screen gradient (errors are stated in pixels). Plus: the motion of the
// camera case equals the reprojection of the raw `position` target, static surfaces have none,
// and the false-colour picture.
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "posed_scenes.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

test::GpuSuite& motionGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kW = 192;
constexpr uint32_t kH = 144;
constexpr float kBarLength = 4.0f;

// A floor, three boxes and a skinned bar (objects 1, 10-12, 20).
scene::Scene motionScene() {
  scene::Scene s;
  s.meshes = {scene::makePlane(4.0f), scene::makeCube(), test::makeBar(kBarLength, 0.3f, 33, 2)};
  s.materials.push_back({"floor", glm::vec3(0.7f), 0.0f, 0.8f});
  s.materials.push_back({"box", glm::vec3(0.3f, 0.5f, 0.8f), 0.0f, 0.5f});
  scene::Material bar{"bar", glm::vec3(0.9f, 0.5f, 0.2f), 0.0f, 0.5f};
  bar.doubleSided = true;
  s.materials.push_back(bar);
  scene::Instance floor{0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(16.0f, 1.0f, 16.0f))};
  floor.object = 1;
  s.instances.push_back(floor);
  const glm::vec3 places[] = {{-2.2f, 0.6f, -0.5f}, {0.9f, 0.6f, 2.4f}, {2.3f, 0.8f, 0.6f}};
  for (uint32_t i = 0; i < 3; ++i) {
    scene::Instance box{1, 1, glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), places[i]),
                                                     0.4f * float(i), glm::vec3(0, 1, 0)),
                                         glm::vec3(1.2f))};
    box.object = 10 + i;
    s.instances.push_back(box);
  }
  scene::Instance skinned{2, 2, glm::translate(glm::mat4(1.0f), glm::vec3(-1.5f, 1.8f, 0.8f))};
  skinned.object = 20;
  skinned.skin = 0;
  s.instances.push_back(skinned);
  test::addBarSkin(s, kBarLength, 2);
  s.sun.direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.2f));
  return s;
}
constexpr uint32_t kMovingBox = 2;  // instance index of object 11
constexpr uint32_t kBar = 4;

scene::Camera cameraAt(glm::vec3 eye, glm::vec3 target) {
  scene::Camera c;
  c.eye = eye;
  c.target = target;
  c.fovYDegrees = 55.0f;
  c.nearPlane = 0.1f;
  c.farPlane = 50.0f;
  return c;
}

// The scene's state at one time: its camera and pose.
struct State {
  scene::Camera camera;
  std::shared_ptr<render::ScenePose> pose;
};

render::Frame renderTarget(const State& s, render::Target target, const State* previous = nullptr,
                           bool raw = true) {
  render::FrameSettings f;
  f.width = kW;
  f.height = kH;
  f.camera = s.camera;
  f.pose = s.pose;
  f.target = target;
  f.raw = raw;
  f.markers = false;
  f.antialias = render::Antialias::None;
  if (previous) {
    f.previousCamera = previous->camera;
    f.previousPose = previous->pose;
  }
  return motionGpu().render(f);
}

glm::vec2 at2(const std::vector<float>& data, int x, int y) {
  const size_t i = (size_t(y) * kW + size_t(x)) * 4;
  return {data[i], data[i + 1]};
}
uint32_t idAt(const render::Frame& f, int x, int y) {
  return std::bit_cast<uint32_t>(f.data[(size_t(y) * kW + size_t(x)) * 4]);
}

struct Warp {
  size_t compared = 0;       // pixels visible in both frames, away from edges
  size_t moving = 0;         // of those, moving by more than a pixel
  double p99 = 0.0;          // the warp's error, pixels: 99th percentile
  double worst = 0.0;
  double movingMedianUnwarped = 0.0;  // the error without the motion, on the moving pixels
};

// Warps frame A's uv by frame B's motion (each pixel p of B takes A's uv at p - motion) and
// measures, in pixels of B, how far the result is from B's own uv.
Warp warpError(const render::Frame& uvA, const render::Frame& uvB, const render::Frame& idA,
               const render::Frame& idB, const render::Frame& motion) {
  std::vector<double> errors, unwarped;
  Warp w;
  auto smooth = [&](const std::vector<float>& uv, int x, int y) {
    // No uv seam across the pixel: its neighbours continue the same gradient.
    const glm::vec2 c = at2(uv, x, y);
    const glm::vec2 dx1 = at2(uv, x + 1, y) - c, dx0 = c - at2(uv, x - 1, y);
    const glm::vec2 dy1 = at2(uv, x, y + 1) - c, dy0 = c - at2(uv, x, y - 1);
    return glm::length(dx1 - dx0) <= 0.25f * std::max(glm::length(dx1), glm::length(dx0)) + 1e-5f &&
           glm::length(dy1 - dy0) <= 0.25f * std::max(glm::length(dy1), glm::length(dy0)) + 1e-5f;
  };
  auto sampleA = [&](glm::vec2 p, uint32_t id, glm::vec2& out) {
    const float fx = p.x - 0.5f, fy = p.y - 0.5f;
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    if (x0 < 1 || y0 < 1 || x0 + 2 >= int(kW) || y0 + 2 >= int(kH)) return false;
    for (int dy = 0; dy <= 1; ++dy) {
      for (int dx = 0; dx <= 1; ++dx) {
        if (idAt(idA, x0 + dx, y0 + dy) != id || !smooth(uvA.data, x0 + dx, y0 + dy)) return false;
      }
    }
    const float tx = fx - float(x0), ty = fy - float(y0);
    out = glm::mix(glm::mix(at2(uvA.data, x0, y0), at2(uvA.data, x0 + 1, y0), tx),
                   glm::mix(at2(uvA.data, x0, y0 + 1), at2(uvA.data, x0 + 1, y0 + 1), tx), ty);
    return true;
  };
  for (int y = 2; y + 2 < int(kH); ++y) {
    for (int x = 2; x + 2 < int(kW); ++x) {
      const uint32_t id = idAt(idB, x, y);
      if (id == 0) continue;
      bool inside = true;
      for (int dy = -1; dy <= 1 && inside; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) inside = inside && idAt(idB, x + dx, y + dy) == id;
      }
      if (!inside || !smooth(uvB.data, x, y)) continue;
      const size_t i = (size_t(y) * kW + size_t(x)) * 4;
      REQUIRE(motion.data[i + 2] == 1.0f);  // a surface, as the id says
      const glm::vec2 m(motion.data[i], motion.data[i + 1]);
      const glm::vec2 centre(float(x) + 0.5f, float(y) + 0.5f);
      glm::vec2 warped, still;
      if (!sampleA(centre - m, id, warped)) continue;  // not visible in A there
      // B's uv gradient: uv error -> pixels.
      const glm::vec2 ddx = 0.5f * (at2(uvB.data, x + 1, y) - at2(uvB.data, x - 1, y));
      const glm::vec2 ddy = 0.5f * (at2(uvB.data, x, y + 1) - at2(uvB.data, x, y - 1));
      const glm::mat2 j(ddx, ddy);
      if (std::abs(glm::determinant(j)) < 1e-10f) continue;
      const glm::mat2 inverse = glm::inverse(j);
      const glm::vec2 uv = at2(uvB.data, x, y);
      const double error = glm::length(inverse * (warped - uv));
      errors.push_back(error);
      ++w.compared;
      if (glm::length(m) > 1.0f) {
        ++w.moving;
        if (sampleA(centre, id, still)) unwarped.push_back(glm::length(inverse * (still - uv)));
      }
    }
  }
  if (!errors.empty()) {
    std::sort(errors.begin(), errors.end());
    w.p99 = errors[size_t(double(errors.size() - 1) * 0.99)];
    w.worst = errors.back();
  }
  if (!unwarped.empty()) {
    std::sort(unwarped.begin(), unwarped.end());
    w.movingMedianUnwarped = unwarped[unwarped.size() / 2];
  }
  return w;
}

// The warp of frame A (time t) by frame B's (t + 1/30) motion: frames A and B of uv and ids, and
// B's motion with A as its previous state.
Warp checkWarp(const State& a, const State& b, const char* name) {
  const render::Frame uvA = renderTarget(a, render::Target::Uv);
  const render::Frame idA = renderTarget(a, render::Target::InstanceId);
  const render::Frame uvB = renderTarget(b, render::Target::Uv);
  const render::Frame idB = renderTarget(b, render::Target::InstanceId);
  const render::Frame motion = renderTarget(b, render::Target::Motion, &a);
  CHECK(std::any_of(motion.passes.begin(), motion.passes.end(),
                    [](const auto& p) { return p.name == "motion"; }));
  const Warp w = warpError(uvA, uvB, idA, idB, motion);
  MESSAGE(std::string(name) << ": " << w.compared << " pixels compared (" << w.moving
               << " moving > 1 px); warp error p99 " << w.p99 << " px, worst " << w.worst
               << " px; unwarped median on moving pixels " << w.movingMedianUnwarped << " px");
  // Stated tolerance: 99% of the pixels visible in both frames within 0.25 px, all within 1 px
  // (the uv target is half-float: about 0.05 px of its own rounding at these sizes).
  CHECK(w.compared > 3000);
  CHECK(w.moving > 300);
  CHECK(w.p99 <= 0.25);
  CHECK(w.worst <= 1.0);
  CHECK(w.movingMedianUnwarped >= 1.0);  // without the motion the frames do not line up
  return w;
}

State base() {
  return {cameraAt({0.5f, 4.0f, 7.5f}, {0.0f, 0.8f, 0.0f}), nullptr};
}

}  // namespace

TEST_CASE("motion: a moving camera, frame t warped by t + 1/30's motion") {
  test::GpuSuite& g = motionGpu();
  g.setScene(motionScene());
  State a = base();
  State b = base();
  b.camera = cameraAt({0.95f, 4.15f, 7.1f}, {0.1f, 0.75f, 0.05f});
  checkWarp(a, b, "camera");

  // Exact: each pixel's motion is its surface point's pixel now minus its projection by the
  // previous camera (the raw position target gives the point).
  const render::Frame position = renderTarget(b, render::Target::Position);
  const render::Frame motion = renderTarget(b, render::Target::Motion, &a);
  const glm::mat4 previous = scene::projectionMatrix(a.camera, float(kW) / float(kH)) * scene::viewMatrix(a.camera);
  double worst = 0.0;
  size_t surface = 0;
  for (uint32_t y = 0; y < kH; ++y) {
    for (uint32_t x = 0; x < kW; ++x) {
      const size_t i = (size_t(y) * kW + x) * 4;
      if (motion.data[i + 2] != 1.0f) continue;
      ++surface;
      const glm::vec4 clip = previous * glm::vec4(position.data[i], position.data[i + 1], position.data[i + 2], 1.0f);
      const glm::vec2 then = (glm::vec2(clip) / clip.w * 0.5f + 0.5f) * glm::vec2(kW, kH);
      const glm::vec2 expected = glm::vec2(float(x) + 0.5f, float(y) + 0.5f) - then;
      worst = std::max(worst, double(glm::length(expected - glm::vec2(motion.data[i], motion.data[i + 1]))));
    }
  }
  MESSAGE("camera: motion against the reprojected position target: worst " << worst << " px over "
                                                                           << surface << " pixels");
  CHECK(surface > 10000);
  CHECK(worst < 0.02);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("motion: a moving object (its transform changed between the frames)") {
  test::GpuSuite& g = motionGpu();
  scene::Scene s = motionScene();
  g.setScene(s);
  const glm::mat4 start = s.instances[kMovingBox].transform;
  State a = base();
  a.pose = std::make_shared<render::ScenePose>();
  a.pose->transforms.push_back({kMovingBox, start});
  State b = base();
  b.pose = std::make_shared<render::ScenePose>();
  b.pose->transforms.push_back(
      {kMovingBox, glm::translate(glm::mat4(1.0f), glm::vec3(0.5f, 0.15f, 0.45f)) * start *
                       glm::rotate(glm::mat4(1.0f), 0.3f, glm::vec3(0.2f, 1.0f, 0.1f))});
  checkWarp(a, b, "object");
  // Nothing else moved: the floor's and the other boxes' motion is zero.
  const render::Frame motion = renderTarget(b, render::Target::Motion, &a);
  const render::Frame ids = renderTarget(b, render::Target::InstanceId);
  double still = 0.0;
  for (size_t i = 0; i < motion.data.size(); i += 4) {
    const uint32_t id = std::bit_cast<uint32_t>(ids.data[i]);
    if (id == 1 || id == 10 || id == 12) still = std::max(still, double(std::hypot(motion.data[i], motion.data[i + 1])));
  }
  MESSAGE("object: the static surfaces' largest motion " << still << " px");
  CHECK(still < 1e-3);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("motion: a bending skin (joint matrices changed between the frames)") {
  test::GpuSuite& g = motionGpu();
  g.setScene(motionScene());
  State a = base();
  a.pose = std::make_shared<render::ScenePose>();
  a.pose->poses.push_back({kBar, test::barPose(kBarLength, {0.1f, 0.6f}), {}});
  State b = base();
  b.pose = std::make_shared<render::ScenePose>();
  b.pose->poses.push_back({kBar, test::barPose(kBarLength, {0.16f, 0.78f}), {}});
  checkWarp(a, b, "skin");
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("motion: the false-colour picture, and frames without a previous state") {
  test::GpuSuite& g = motionGpu();
  g.setScene(motionScene());
  State a = base();
  State b = base();
  b.camera = cameraAt({0.95f, 4.15f, 7.1f}, {0.1f, 0.75f, 0.05f});
  const render::Frame picture = renderTarget(b, render::Target::Motion, &a, false);
  size_t black = 0, coloured = 0;
  const auto px = picture.pixels();
  for (size_t i = 0; i < px.size(); i += 4) {
    if (px[i] == 0 && px[i + 1] == 0 && px[i + 2] == 0) ++black;
    if (std::min({px[i], px[i + 1], px[i + 2]}) < 200) ++coloured;
  }
  MESSAGE("picture: " << black << " background pixels, " << coloured << " coloured");
  CHECK(coloured > 5000);
  // No previous state: nothing moved.
  const render::Frame none = renderTarget(b, render::Target::Motion);
  double most = 0.0;
  for (size_t i = 0; i < none.data.size(); i += 4) most = std::max(most, double(std::hypot(none.data[i], none.data[i + 1])));
  CHECK(most < 1e-3);  // the previous camera is the frame's (float rounding of the same matrix)
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("motion: morph targets (weights changed between the frames)") {
  test::GpuSuite& g = motionGpu();
  scene::Scene s = motionScene();
  s.meshes.push_back(test::makeMorphGrid(3.0f, 32));
  scene::Instance grid{3, 1, glm::translate(glm::mat4(1.0f), glm::vec3(0.3f, 1.2f, 1.5f))};
  grid.object = 30;
  s.instances.push_back(grid);
  g.setScene(s);
  const uint32_t index = uint32_t(s.instances.size() - 1);
  State a = base();
  a.pose = std::make_shared<render::ScenePose>();
  a.pose->poses.push_back({index, {}, {0.2f, 0.1f}});
  State b = base();
  b.pose = std::make_shared<render::ScenePose>();
  b.pose->poses.push_back({index, {}, {0.55f, -0.2f}});
  checkWarp(a, b, "morph");
  CHECK(g.context->validationMessages.load() == 0);
}
