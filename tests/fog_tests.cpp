// Distance fog (settings fog; render/frame_passes/fog.cpp, shaders/fog.comp), with validation on.
// A floor running off towards the horizon with two boxes on it, seen from a little above, so that
// surfaces lie from a few metres to tens of metres away and the background shows above the
// horizon. Judged on raw `final` (the lit HDR values, half floats) against the same frame without
// fog and the raw `position` view of that frame: each surface pixel must be
// mix(fog colour, unfogged, exp(-density * distance)), each background pixel as it was.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "render/renderer.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using Gpu = test::GpuSuite;

Gpu& sharedGpu() {
  static Gpu gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 128;
constexpr uint32_t kHeight = 96;

scene::Scene fieldScene() {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(8.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.7f), 0.0f, 0.8f});
  s.materials.push_back({"box", glm::vec3(0.8f, 0.3f, 0.2f), 0.0f, 0.5f});
  // 80 m of floor ahead of the camera.
  s.instances.push_back({0, 0, glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, -30.0f)),
                                          glm::vec3(80.0f, 1.0f, 80.0f))});
  s.instances.push_back({1, 1, glm::translate(glm::mat4(1.0f), glm::vec3(-1.0f, 0.5f, 0.0f))});
  s.instances.push_back({1, 1, glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(3.0f, 1.5f, -20.0f)),
                                          glm::vec3(3.0f))});
  s.lights = {{glm::vec3(0.5f, 1.0f, 1.0f), 4.0f, glm::vec3(1.0f, 0.8f, 0.5f), 3.0f, 1.0f}};
  s.sun.direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.4f));
  s.sun.intensity = 2.0f;
  s.ambient = glm::vec3(0.05f);
  s.background = glm::vec3(0.1f, 0.2f, 0.4f);
  return s;
}

render::FrameSettings frameOf(render::Technique technique, bool raw,
                              render::Target target = render::Target::Final) {
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera.eye = glm::vec3(0.0f, 1.6f, 6.0f);
  f.camera.target = glm::vec3(0.0f, 1.0f, -10.0f);
  f.camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
  f.camera.fovYDegrees = 60.0f;
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 200.0f;
  f.target = target;
  f.technique = technique;
  f.markers = false;
  f.raw = raw;
  return f;
}

bool ranFog(const render::Frame& frame) {
  return std::any_of(frame.passes.begin(), frame.passes.end(),
                     [](const render::PassTiming& p) { return p.name == "fog"; });
}

}  // namespace

TEST_CASE("fog: every surface pixel is mix(fog, unfogged, exp(-density * distance)); the background is unchanged") {
  Gpu& gpu = sharedGpu();
  gpu.setScene(fieldScene());
  constexpr float kDensity = 0.08f;
  const glm::vec3 fogColor(0.6f, 0.5f, 0.3f);
  for (render::Technique technique : render::allTechniques()) {
    CAPTURE(render::techniqueName(technique));
    const render::FrameSettings plain = frameOf(technique, true);
    const render::Frame unfogged = gpu.render(plain);
    const render::Frame position = gpu.render(frameOf(technique, true, render::Target::Position));
    render::FrameSettings foggy = plain;
    foggy.fog.density = kDensity;
    foggy.fog.color = fogColor;
    const render::Frame fogged = gpu.render(foggy);
    REQUIRE(unfogged.data.size() == size_t(kWidth) * kHeight * 4);
    REQUIRE(fogged.data.size() == unfogged.data.size());
    REQUIRE(position.data.size() == unfogged.data.size());
    CHECK(ranFog(fogged));
    CHECK(!ranFog(unfogged));

    size_t surfaces = 0, background = 0, changedBackground = 0, outside = 0;
    size_t outsideIfOff = 0;  // the same comparison with a density 5% off: it must tell them apart
    float nearest = 1e30f, farthest = 0.0f, worst = 0.0f;
    for (size_t i = 0; i < size_t(kWidth) * kHeight; ++i) {
      const float* before = &unfogged.data[i * 4];
      const float* after = &fogged.data[i * 4];
      const float* p = &position.data[i * 4];
      if (p[3] == 0.0f) {  // no surface: the raw position view's alpha is 0 there
        ++background;
        if (!std::equal(before, before + 4, after)) ++changedBackground;
        continue;
      }
      ++surfaces;
      const float distance = glm::length(glm::vec3(p[0], p[1], p[2]) - plain.camera.eye);
      nearest = std::min(nearest, distance);
      farthest = std::max(farthest, distance);
      const float kept = std::exp(-kDensity * distance);
      for (int c = 0; c < 3; ++c) {
        const float expected = fogColor[c] + (before[c] - fogColor[c]) * kept;
        // Half floats keep 11 significant bits (relative 2^-11 per rounding), and the shader
        // finds the distance from depth with float arithmetic of its own.
        const float error = std::abs(after[c] - expected);
        const float tolerance = 2e-3f * std::max(std::abs(expected), 0.05f);
        worst = std::max(worst, error / std::max(std::abs(expected), 0.05f));
        if (error > tolerance) ++outside;
        const float wrong = fogColor[c] + (before[c] - fogColor[c]) * std::exp(-1.05f * kDensity * distance);
        if (c == 0 && std::abs(after[c] - wrong) > tolerance) ++outsideIfOff;
      }
    }
    std::printf("fog (%s): %zu surface pixels from %.1f to %.1f m, %zu background; worst relative "
                "error %.2e; %zu would be off with a density 5%% off\n",
                std::string(render::techniqueName(technique)).c_str(), surfaces, nearest, farthest,
                background, worst, outsideIfOff);
    CHECK(surfaces > size_t(kWidth) * kHeight / 3);
    CHECK(background > size_t(kWidth) * 8);  // the sky above the horizon
    CHECK(nearest < 6.0f);
    CHECK(farthest > 40.0f);
    CHECK(outside == 0);
    CHECK(outsideIfOff > surfaces / 2);
    CHECK(changedBackground == 0);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("fog: off (density 0) is the frame without fog byte for byte, and runs no pass; data views ignore it") {
  Gpu& gpu = sharedGpu();
  gpu.setScene(fieldScene());
  for (bool raw : {false, true}) {
    CAPTURE(raw);
    render::FrameSettings plain = frameOf(render::Technique::Clustered, raw);
    const render::Frame before = gpu.render(plain);
    render::FrameSettings off = plain;
    off.fog.density = 0.0f;
    off.fog.color = glm::vec3(5.0f, 0.0f, 3.0f);  // a colour that would show if anything used it
    const render::Frame after = gpu.render(off);
    CHECK(before.rgba == after.rgba);
    CHECK(before.data == after.data);
    CHECK(!ranFog(after));
    // On, the picture changes (and the 8-bit one runs the pass too).
    render::FrameSettings on = plain;
    on.fog.density = 0.05f;
    const render::Frame foggy = gpu.render(on);
    CHECK(ranFog(foggy));
    CHECK((raw ? foggy.data != before.data : foggy.rgba != before.rgba));
  }
  // A data view shows the G-buffer, not the lit picture: fog leaves it as it is.
  render::FrameSettings depth = frameOf(render::Technique::Clustered, true, render::Target::Depth);
  const render::Frame plainDepth = gpu.render(depth);
  depth.fog.density = 0.05f;
  const render::Frame foggyDepth = gpu.render(depth);
  CHECK(plainDepth.data == foggyDepth.data);
  CHECK(!ranFog(foggyDepth));
  CHECK(gpu.context->validationMessages.load() == 0);
}
