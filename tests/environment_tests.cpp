// The environment light (image-based lighting) on the GPU, validation on: a metallic sphere under
// the procedural sky with every other light off is lit and not flat, agrees with the C++ reference
// (which builds the same maps with the same functions, shaders/environment.glsl) and agrees
// across the three techniques; an .hdr environment, rotated and shown as the background, agrees
// with the reference on every pixel, background included; the maps are rebuilt only when what
// they come from changes.
//
// Metrics (on the raw linear `final` output over the sphere's pixels, found by the raw depth
// target): luminance Y = 0.2126 R + 0.7152 G + 0.0722 B; "not black" is mean Y > 0.1, "not flat"
// is the standard deviation of Y > 0.03 (measured on lavapipe: see the MESSAGE lines). Reference:
// at most 2/255 on every pixel but 0.5% (silhouette pixel centres may fall either side). The
// techniques: at most 1/255 apart on every pixel.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "image_compare.h"
#include "render/reference.h"
#include "render/renderer.h"
#include "scene/environment_map.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

test::GpuSuite& environmentGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

// A metallic sphere alone; the sun is off and nothing else lights it.
scene::Scene sphereScene() {
  scene::Scene s;
  s.meshes.push_back(scene::makeSphere(64, 32));
  s.materials.push_back({"chrome", glm::vec3(0.95f, 0.93f, 0.88f), 1.0f, 0.3f});
  s.instances.push_back({0, 0, glm::mat4(1.0f)});
  s.sun.direction = glm::normalize(glm::vec3(-0.4f, -0.6f, -0.5f));
  s.sun.color = glm::vec3(1.0f, 0.95f, 0.9f);
  s.sun.intensity = 0.0f;
  s.ambient = glm::vec3(0.0f);
  s.background = glm::vec3(0.0f);
  return s;
}

render::FrameSettings frameOf(render::EnvironmentMode mode) {
  render::FrameSettings f;
  f.width = 96;
  f.height = 96;
  f.camera.eye = glm::vec3(0.0f, 0.6f, 3.2f);
  f.camera.target = glm::vec3(0.0f);
  f.camera.fovYDegrees = 45.0f;
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 50.0f;
  f.markers = false;
  f.antialias = render::Antialias::None;  // compared with the reference, which does not anti-alias
  f.environment.mode = mode;
  return f;
}

struct SphereStats {
  double meanLuminance = 0;
  double deviation = 0;
  size_t pixels = 0;
  size_t nonFinite = 0;
};

SphereStats sphereStats(test::GpuSuite& gpu, render::FrameSettings f) {
  f.raw = true;
  f.target = render::Target::Depth;
  const render::Frame depth = gpu.render(f);
  f.target = render::Target::Final;
  const render::Frame final = gpu.render(f);
  SphereStats s;
  double sum = 0, sum2 = 0;
  for (size_t p = 0; p < size_t(f.width) * f.height; ++p) {
    for (int c = 0; c < 4; ++c) s.nonFinite += std::isfinite(final.data[p * 4 + c]) ? 0 : 1;
    if (depth.data[p * 4] >= f.camera.farPlane * 0.999f) continue;
    const double y = 0.2126 * final.data[p * 4] + 0.7152 * final.data[p * 4 + 1] +
                     0.0722 * final.data[p * 4 + 2];
    sum += y;
    sum2 += y * y;
    ++s.pixels;
  }
  if (s.pixels > 0) {
    s.meanLuminance = sum / double(s.pixels);
    s.deviation = std::sqrt(std::max(0.0, sum2 / double(s.pixels) - s.meanLuminance * s.meanLuminance));
  }
  return s;
}

// A synthetic equirectangular environment: a warm band with a bright spot above a blue floor.
scene::EnvironmentImage testImage() {
  std::vector<float> rgb;
  const uint32_t w = 64, h = 32;
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      float r = y < h / 2 ? 1.5f + float(x) / float(w) : 0.03f;
      float g = y < h / 2 ? 0.7f : 0.06f;
      float b = y < h / 2 ? 0.2f : 0.35f;
      if (x >= 40 && x < 44 && y >= 8 && y < 11) r = g = b = 30.0f;  // a "sun"
      rgb.insert(rgb.end(), {r, g, b});
    }
  }
  return scene::resampleEquirect(rgb, w, h);
}

}  // namespace

TEST_CASE("environment: a metallic sphere under the sky alone is lit, not flat, and matches the reference") {
  test::GpuSuite& gpu = environmentGpu();
  const scene::Scene scene = sphereScene();
  gpu.setScene(scene);
  render::FrameSettings f = frameOf(render::EnvironmentMode::Sky);

  const SphereStats sky = sphereStats(gpu, f);
  MESSAGE("sky: " << sky.pixels << " sphere pixels, mean luminance " << sky.meanLuminance
                  << ", standard deviation " << sky.deviation);
  CHECK(sky.pixels > 1500);
  CHECK(sky.nonFinite == 0);
  CHECK(sky.meanLuminance > 0.1);
  CHECK(sky.deviation > 0.03);
  // The seed's constant ambient (0 here) leaves the same sphere black.
  const SphereStats none = sphereStats(gpu, frameOf(render::EnvironmentMode::None));
  CHECK(none.meanLuminance == 0.0);

  // The reference builds the same maps on the CPU and shades with the same code.
  render::FrameSettings lit = f;
  lit.takeLightingFrom(scene);
  const render::Frame image = gpu.render(f);
  const std::vector<uint8_t> reference = render::renderReference(scene, lit);
  const int worst = test::maxDifference(image.rgba, reference);
  const size_t over = test::pixelsOver(image.rgba, reference, 2);
  MESSAGE("sky vs reference: max difference " << worst << "/255, " << over << " pixels over 2");
  CHECK(over <= image.rgba.size() / 4 / 200);

  // Every technique adds it the same way.
  for (render::Technique t : {render::Technique::Volumes, render::Technique::Tiled}) {
    render::FrameSettings other = f;
    other.technique = t;
    const render::Frame frame = gpu.render(other);
    CAPTURE(render::techniqueName(t));
    CHECK(test::maxDifference(frame.rgba, image.rgba) <= 1);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("environment: the sky follows the sun; maps are rebuilt only when their inputs change") {
  test::GpuSuite& gpu = environmentGpu();
  scene::Scene scene = sphereScene();
  gpu.setScene(scene);
  render::FrameSettings f = frameOf(render::EnvironmentMode::Sky);
  const render::Frame first = gpu.render(f);
  const uint64_t built = gpu.renderer->environmentRebuilds(gpu.scene);
  CHECK(built >= 1);
  // Intensity, rotation, background, technique and size cost no rebuild.
  render::FrameSettings same = f;
  same.environment.intensity = 0.5f;
  same.environment.background = true;
  same.technique = render::Technique::Tiled;
  const render::Frame dimmer = gpu.render(same);
  CHECK(gpu.renderer->environmentRebuilds(gpu.scene) == built);
  CHECK(test::pixelsOver(dimmer.rgba, first.rgba, 4) > 1000);
  // A lower sun changes the sky (and the sphere), with one rebuild.
  scene.sun.direction = glm::normalize(glm::vec3(0.5f, -0.08f, 0.6f));
  gpu.setScene(scene);
  const render::Frame evening = gpu.render(f);
  CHECK(gpu.renderer->environmentRebuilds(gpu.scene) == built + 1);
  CHECK(test::pixelsOver(evening.rgba, first.rgba, 4) > 1000);
  gpu.render(f);
  CHECK(gpu.renderer->environmentRebuilds(gpu.scene) == built + 1);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("environment: an .hdr, rotated and shown as the background, matches the reference everywhere") {
  test::GpuSuite& gpu = environmentGpu();
  scene::Scene scene = sphereScene();
  scene.materials[0].roughness = 0.1f;
  scene.meshes.push_back(scene::makeSphere(48, 24));
  scene.materials.push_back({"plastic", glm::vec3(0.2f, 0.6f, 0.3f), 0.0f, 0.6f});
  scene.instances.push_back(
      {1, 1, glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(1.3f, -0.4f, 0.3f)), glm::vec3(0.5f))});
  gpu.setScene(scene);
  auto image = std::make_shared<const scene::EnvironmentImage>(testImage());
  gpu.renderer->setEnvironmentImage(gpu.scene, image);
  render::FrameSettings f = frameOf(render::EnvironmentMode::Hdr);
  f.environment.rotation = 0.9f;
  f.environment.background = true;
  f.environment.intensity = 0.7f;

  const SphereStats stats = sphereStats(gpu, f);
  CHECK(stats.nonFinite == 0);
  const render::Frame frame = gpu.render(f);
  render::FrameSettings lit = f;
  lit.takeLightingFrom(scene);
  const std::vector<uint8_t> reference = render::renderReference(scene, lit, image.get());
  const int worst = test::maxDifference(frame.rgba, reference);
  const size_t over = test::pixelsOver(frame.rgba, reference, 2);
  MESSAGE("hdr vs reference: max difference " << worst << "/255, " << over << " pixels over 2");
  // At most 1% of the pixels 3/255 off (silhouettes, and background taps that round the other
  // way): lavapipe stays under 0.5%, the NVIDIA H200 had 55 of 9,216 pixels (0.6%).
  CHECK(over <= frame.rgba.size() / 4 / 100);
  // The rotation turns the environment: another picture.
  render::FrameSettings turned = f;
  turned.environment.rotation = 2.5f;
  CHECK(test::pixelsOver(gpu.render(turned).rgba, frame.rgba, 4) > 1000);
  // Every technique, background included.
  for (render::Technique t : {render::Technique::Volumes, render::Technique::Tiled}) {
    render::FrameSettings other = f;
    other.technique = t;
    CAPTURE(render::techniqueName(t));
    CHECK(test::maxDifference(gpu.render(other).rgba, frame.rgba) <= 1);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("environment: the material's occlusion scales the environment light, and not the sun") {
  test::GpuSuite& gpu = environmentGpu();
  scene::Scene scene = sphereScene();
  // A 1x1 occlusion map of 64/255 (linear, R): occlusion = 1 + strength (0.251 - 1).
  scene.images.push_back({"ao", 1, 1, {64, 64, 64, 255}});
  scene.materials[0].occlusionTexture.image = 0;
  gpu.setScene(scene);
  const SphereStats occluded = sphereStats(gpu, frameOf(render::EnvironmentMode::Sky));
  scene.materials[0].occlusionStrength = 0.0f;  // occlusion 1
  gpu.setScene(scene);
  const SphereStats open = sphereStats(gpu, frameOf(render::EnvironmentMode::Sky));
  REQUIRE(open.meanLuminance > 0.1);
  const double ratio = occluded.meanLuminance / open.meanLuminance;
  MESSAGE("environment light with occlusion 64/255: " << ratio << " of it without");
  CHECK(ratio == doctest::Approx(64.0 / 255.0).epsilon(0.02));

  // The sun is direct light: the same picture with and without the occlusion map.
  scene.sun.intensity = 3.0f;
  gpu.setScene(scene);
  const render::Frame sunOpen = gpu.render(frameOf(render::EnvironmentMode::None));
  scene.materials[0].occlusionStrength = 1.0f;
  gpu.setScene(scene);
  const render::Frame sunOccluded = gpu.render(frameOf(render::EnvironmentMode::None));
  CHECK(test::maxDifference(sunOpen.rgba, sunOccluded.rgba) <= 1);
  CHECK(gpu.context->validationMessages.load() == 0);
}
