// Alpha-blended surfaces (glTF alphaMode BLEND): the forward pass after lighting
// (render/passes.cpp, recordBlendPass; shaders/forward.glsl), on whatever device is present
// (lavapipe in CI) with validation on.
//
// What is expected comes from the same renderer with the blended quads made opaque (their lit
// colour F) and removed (what lies behind them, G): a quad of alpha a must show a F + (1 - a) G.
// F comes through the G-buffer (8-bit sRGB base colour) and the blended quad does not, so the
// tolerance is 1.5% of the value plus 0.002.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "render/renderer.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

test::GpuSuite& blendGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 96;
constexpr uint32_t kHeight = 64;

scene::Camera frontCamera() {
  scene::Camera c;
  c.eye = glm::vec3(0.0f, 0.0f, 4.0f);
  c.target = glm::vec3(0.0f, 0.0f, 0.0f);
  c.fovYDegrees = 40.0f;
  c.nearPlane = 0.5f;
  c.farPlane = 20.0f;
  return c;
}

// A plane facing +Z (makePlane faces +Y) of side `size` centred at `at`.
glm::mat4 facingCamera(glm::vec3 at, float size) {
  return glm::translate(glm::mat4(1.0f), at) *
         glm::rotate(glm::mat4(1.0f), glm::radians(90.0f), glm::vec3(1.0f, 0.0f, 0.0f)) *
         glm::scale(glm::mat4(1.0f), glm::vec3(size, 1.0f, size));
}

scene::Material quadMaterial(const char* name, glm::vec3 color, float alpha, scene::AlphaMode mode) {
  scene::Material m;
  m.name = name;
  m.baseColor = color;
  m.metallic = 0.0f;
  m.roughness = 0.7f;
  m.alpha = alpha;
  m.alphaMode = mode;
  return m;
}

// A blue wall at z = -2 (4 m wide: the frame's left and right edges show the background past it)
// and the quads in `quads` (material, transform), lit by a sun and two short-range point lights
// that reach the quads but not the wall: a blended quad missing its local light (a cluster
// without a list) would be visibly darker.
scene::Scene blendScene(const std::vector<std::pair<scene::Material, glm::mat4>>& quads) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane());
  s.materials.push_back(quadMaterial("wall", glm::vec3(0.2f, 0.45f, 0.8f), 1.0f, scene::AlphaMode::opaque));
  s.instances.push_back({0, 0, facingCamera(glm::vec3(0.0f, 0.0f, -2.0f), 4.0f)});
  for (const auto& [material, transform] : quads) {
    s.materials.push_back(material);
    s.instances.push_back({0, uint32_t(s.materials.size() - 1), transform});
  }
  s.sun.direction = glm::normalize(glm::vec3(0.3f, -0.4f, -1.0f));
  s.sun.intensity = 1.5f;
  s.ambient = glm::vec3(0.05f);
  s.background = glm::vec3(0.3f, 0.25f, 0.1f);
  s.lights = {{glm::vec3(-0.6f, 0.2f, 0.9f), 1.6f, glm::vec3(1.0f, 0.9f, 0.8f), 6.0f, 1.0f},
              {glm::vec3(2.0f, -0.2f, 0.9f), 1.6f, glm::vec3(0.8f, 0.9f, 1.0f), 6.0f, 1.0f}};
  return s;
}

std::vector<float> renderRaw(const scene::Scene& s, render::Technique technique,
                             render::EnvironmentMode environment) {
  test::GpuSuite& gpu = blendGpu();
  gpu.setScene(s);
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera = frontCamera();
  f.markers = false;
  f.raw = true;
  f.technique = technique;
  f.environment.mode = environment;
  render::Frame frame = gpu.render(f);
  REQUIRE(frame.data.size() == size_t(kWidth) * kHeight * 4);
  for (float v : frame.data) REQUIRE(std::isfinite(v));
  CHECK(gpu.context->validationMessages.load() == 0);
  return frame.data;
}

glm::vec3 at(const std::vector<float>& image, glm::ivec2 p) {
  const size_t i = (size_t(p.y) * kWidth + p.x) * 4;
  return {image[i], image[i + 1], image[i + 2]};
}

glm::ivec2 pixelOf(glm::vec3 point) {
  const scene::Camera c = frontCamera();
  glm::vec4 clip = scene::projectionMatrix(c, float(kWidth) / float(kHeight)) * scene::viewMatrix(c) *
                   glm::vec4(point, 1.0f);
  glm::vec2 ndc = glm::vec2(clip) / clip.w;
  glm::vec2 pixel = (ndc * 0.5f + 0.5f) * glm::vec2(kWidth, kHeight);
  return glm::ivec2(pixel);
}

void checkNear(glm::vec3 got, glm::vec3 expected, const char* what) {
  for (int c = 0; c < 3; ++c) {
    CHECK_MESSAGE(std::abs(got[c] - expected[c]) <= 0.015f * expected[c] + 0.002f,
                  std::string(what) << " channel " << c << ": " << got[c] << ", expected " << expected[c]);
  }
}

const render::Technique kTechniques[] = {render::Technique::Volumes, render::Technique::Tiled,
                                         render::Technique::Clustered};

}  // namespace

TEST_CASE("alpha blend: a half-transparent quad shows a F + (1 - a) G over the wall and over the background, in every technique") {
  // Quad 1 in front of the wall, quad 2 half over the background past the wall's right edge.
  const glm::vec3 q1(-0.6f, 0.1f, 0.0f);
  const glm::vec3 q2(2.0f, -0.2f, 0.0f);
  const glm::mat4 t1 = facingCamera(q1, 1.0f), t2 = facingCamera(q2, 0.8f);
  const glm::vec3 red(0.9f, 0.25f, 0.1f), green(0.2f, 0.8f, 0.3f);
  const float alpha = 0.5f;
  auto quads = [&](scene::AlphaMode mode) {
    return blendScene({{quadMaterial("red", red, alpha, mode), t1},
                       {quadMaterial("green", green, alpha, mode), t2}});
  };
  const scene::Scene blended = quads(scene::AlphaMode::blend);
  const scene::Scene opaque = quads(scene::AlphaMode::opaque);
  const scene::Scene behind = blendScene({});
  // Probes: quad 1's centre over the wall; a point of quad 2 whose ray misses the wall (the
  // background behind it), checked below.
  const glm::ivec2 p1 = pixelOf(q1);
  const glm::ivec2 p2 = pixelOf(q2 + glm::vec3(0.2f, 0.0f, 0.0f));
  for (render::EnvironmentMode environment : {render::EnvironmentMode::None, render::EnvironmentMode::Sky}) {
    for (render::Technique technique : kTechniques) {
      CAPTURE(render::techniqueName(technique));
      CAPTURE(render::environmentModeName(environment));
      const std::vector<float> withQuads = renderRaw(blended, technique, environment);
      const std::vector<float> front = renderRaw(opaque, technique, environment);
      const std::vector<float> back = renderRaw(behind, technique, environment);
      for (glm::ivec2 p : {p1, p2}) {
        CAPTURE(p.x);
        CAPTURE(p.y);
        const glm::vec3 f = at(front, p), g = at(back, p);
        // The local lights reach the quads: lit, they are clearly brighter than by the sun alone.
        checkNear(at(withQuads, p), alpha * f + (1.0f - alpha) * g, "blended");
      }
      // Quad 2's probe really is over the background, and the background is what it blends with.
      checkNear(at(back, p2), blended.background,
                "background behind quad 2");
      // Nothing but the quads changed: the wall away from them is untouched.
      const glm::ivec2 wall = pixelOf(glm::vec3(0.9f, -0.8f, -2.0f));
      checkNear(at(withQuads, wall), at(back, wall), "wall");
    }
  }
}

TEST_CASE("alpha blend: overlapping blended quads are drawn back to front whatever the scene's order") {
  const glm::vec3 centre(0.0f, 0.0f, 0.0f);
  const glm::vec3 red(0.9f, 0.2f, 0.1f), green(0.1f, 0.8f, 0.2f);
  // The near quad (red, z = 0.6) comes first in the scene, the far one (green, z = 0) second.
  const glm::mat4 nearT = facingCamera(centre + glm::vec3(0.0f, 0.0f, 0.6f), 0.8f);
  const glm::mat4 farT = facingCamera(centre, 1.2f);
  const float aNear = 0.6f, aFar = 0.5f;
  auto scene = [&](scene::AlphaMode nearMode, scene::AlphaMode farMode, bool withNear, bool withFar) {
    std::vector<std::pair<scene::Material, glm::mat4>> q;
    if (withNear) q.push_back({quadMaterial("near", red, aNear, nearMode), nearT});
    if (withFar) q.push_back({quadMaterial("far", green, aFar, farMode), farT});
    return blendScene(q);
  };
  const glm::ivec2 p = pixelOf(centre);
  for (render::Technique technique : kTechniques) {
    CAPTURE(render::techniqueName(technique));
    const auto env = render::EnvironmentMode::None;
    const glm::vec3 n = at(renderRaw(scene(scene::AlphaMode::opaque, scene::AlphaMode::opaque, true, false), technique, env), p);
    const glm::vec3 f = at(renderRaw(scene(scene::AlphaMode::opaque, scene::AlphaMode::opaque, false, true), technique, env), p);
    const glm::vec3 g = at(renderRaw(scene({}, {}, false, false), technique, env), p);
    const glm::vec3 got = at(renderRaw(scene(scene::AlphaMode::blend, scene::AlphaMode::blend, true, true), technique, env), p);
    const glm::vec3 backToFront = aNear * n + (1.0f - aNear) * (aFar * f + (1.0f - aFar) * g);
    const glm::vec3 frontToBack = aFar * f + (1.0f - aFar) * (aNear * n + (1.0f - aNear) * g);
    MESSAGE(render::techniqueName(technique) << ": got " << got.r << " " << got.g << " " << got.b
            << ", back to front " << backToFront.r << " " << backToFront.g << " " << backToFront.b
            << ", the scene's order " << frontToBack.r << " " << frontToBack.g << " " << frontToBack.b);
    checkNear(got, backToFront, "two quads");
    // The two orders differ enough for this to tell them apart.
    CHECK(std::abs(backToFront.r - frontToBack.r) > 0.1f * backToFront.r);
  }
}
