// GPU images of small analytic scenes, rendered through the real frame on whatever Vulkan device
// is present (lavapipe in CI) with validation on, compared pixel by pixel with the C++ reference
// (render/reference.h).
//
// Tolerance: the reference rounds wherever the GPU stores, so the remaining differences are float
// evaluation order and half-float blending: at most 2/255 per channel on every pixel of scenes
// without silhouettes. Where object silhouettes are in view, pixel centres exactly on an edge may
// fall on either side, so up to 0.5% of pixels may differ by more.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <memory>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "render/reference.h"
#include "render/renderer.h"
#include "scene/builtin_scene.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using Gpu = test::GpuSuite;

// One device for the whole suite: creating instances per test would dominate the run time.
Gpu& sharedGpu() {
  static Gpu gpu = [] {
    Gpu g = test::createGpuSuite();
    std::printf("GPU tests on %s (%s)\n", g.context->info.name.c_str(), g.context->info.type.c_str());
    return g;
  }();
  return gpu;
}

struct Comparison {
  int maxDifference = 0;
  size_t pixelsOver = 0;  // pixels with a channel differing by more than the tolerance
  size_t pixels = 0;
};

Comparison compare(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int tolerance) {
  REQUIRE(a.size() == b.size());
  Comparison c;
  c.pixels = a.size() / 4;
  for (size_t p = 0; p < c.pixels; ++p) {
    int worst = 0;
    for (int ch = 0; ch < 3; ++ch) worst = std::max(worst, std::abs(int(a[p * 4 + ch]) - int(b[p * 4 + ch])));
    c.maxDifference = std::max(c.maxDifference, worst);
    if (worst > tolerance) ++c.pixelsOver;
  }
  return c;
}

// A 40 m floor, mid-grey, slightly rough; a dim sun so local lights dominate where present.
scene::Scene floorScene() {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.materials.push_back({"floor", glm::vec3(0.5f, 0.45f, 0.4f), 0.0f, 0.6f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(40.0f, 1.0f, 40.0f))});
  s.sun.direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.2f));
  s.sun.intensity = 0.4f;
  s.ambient = glm::vec3(0.02f);
  return s;
}

render::FrameSettings settingsFor(const scene::Camera& camera, render::Target target, uint32_t w = 96,
                                  uint32_t h = 64) {
  render::FrameSettings f;
  f.width = w;
  f.height = h;
  f.camera = camera;
  f.target = target;
  f.markers = false;
  f.antialias = render::Antialias::None;  // compared with the reference, which does not anti-alias
  return f;
}

scene::Camera lookingDownAtFloor() {
  scene::Camera c;
  c.eye = glm::vec3(0.0f, 3.0f, 5.0f);
  c.target = glm::vec3(0.0f, 0.0f, -1.0f);
  c.fovYDegrees = 60.0f;
  c.nearPlane = 0.1f;
  c.farPlane = 100.0f;
  return c;
}

Comparison renderAndCompare(const scene::Scene& s, const render::FrameSettings& f, int tolerance) {
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  render::Frame frame = gpu.render(f);
  REQUIRE(frame.width == f.width);
  REQUIRE(frame.height == f.height);
  if (f.target == render::Target::Final) {
    // The raw HDR values behind the image: a NaN or Inf would be clamped away by the 8-bit output.
    render::FrameSettings raw = f;
    raw.raw = true;
    render::Frame values = gpu.render(raw);
    REQUIRE(values.data.size() == size_t(f.width) * f.height * 4);
    size_t nonFinite = 0;
    for (float v : values.data) nonFinite += std::isfinite(v) ? 0 : 1;
    CHECK_MESSAGE(nonFinite == 0, nonFinite << " non-finite values in raw final ("
                                            << render::techniqueName(f.technique) << ")");
  }
  std::vector<uint8_t> reference = render::renderReference(s, render::FrameSettings(f).takeLightingFrom(s));
  Comparison c = compare(frame.rgba, reference, tolerance);
  MESSAGE("target " << render::targetName(f.target) << ": max difference " << c.maxDifference
                    << "/255, " << c.pixelsOver << " of " << c.pixels << " pixels over " << tolerance);
  CHECK(gpu.context->validationMessages.load() == 0);
  return c;
}

}  // namespace

TEST_CASE("sun and ambient on a floor match the reference on every pixel") {
  Comparison c = renderAndCompare(floorScene(), settingsFor(lookingDownAtFloor(), render::Target::Final), 2);
  CHECK(c.pixelsOver == 0);
}

TEST_CASE("local lights on a floor match the reference on every pixel") {
  scene::Scene s = floorScene();
  s.lights = {
      {glm::vec3(0.0f, 0.5f, 0.0f), 2.5f, glm::vec3(1.0f, 0.3f, 0.1f), 6.0f, 1.0f},
      {glm::vec3(-2.0f, 0.3f, -2.0f), 1.5f, glm::vec3(0.2f, 0.5f, 1.0f), 8.0f, 4.0f},
      {glm::vec3(1.5f, 0.2f, 1.0f), 1.0f, glm::vec3(0.2f, 1.0f, 0.3f), 5.0f, 0.0f},
      {glm::vec3(0.5f, 0.1f, -0.5f), 0.05f, glm::vec3(1.0f), 20.0f, 1.0f},  // tiny
      {glm::vec3(0.0f, 1.0f, -30.0f), 4.0f, glm::vec3(1.0f, 1.0f, 0.2f), 3.0f, 1.0f},  // far away
  };
  Comparison c = renderAndCompare(s, settingsFor(lookingDownAtFloor(), render::Target::Final), 2);
  CHECK(c.pixelsOver == 0);
  // And the lights are really there: the GPU image differs from the sun-only one.
  Gpu& gpu = sharedGpu();
  render::Frame lit = gpu.render(settingsFor(lookingDownAtFloor(), render::Target::Final));
  gpu.setScene(floorScene());
  render::Frame unlit = gpu.render(settingsFor(lookingDownAtFloor(), render::Target::Final));
  CHECK(compare(lit.rgba, unlit.rgba, 8).pixelsOver > lit.rgba.size() / 4 / 10);
}

TEST_CASE("camera inside a light volume: no missing or doubled light") {
  scene::Scene s = floorScene();
  scene::Camera camera = lookingDownAtFloor();
  camera.eye = glm::vec3(0.0f, 1.2f, 2.0f);
  camera.target = glm::vec3(0.0f, 0.0f, 0.0f);
  // The eye is 0.9 m from the light and well inside its 4 m sphere; the floor inside is lit.
  s.lights = {{glm::vec3(0.0f, 0.8f, 1.2f), 4.0f, glm::vec3(1.0f, 0.8f, 0.6f), 4.0f, 1.0f}};
  Comparison c = renderAndCompare(s, settingsFor(camera, render::Target::Final), 2);
  CHECK(c.pixelsOver == 0);
}

TEST_CASE("a light volume crossing the near plane: no missing or doubled light") {
  scene::Scene s = floorScene();
  scene::Camera camera;
  camera.eye = glm::vec3(0.0f, 0.6f, 3.0f);
  camera.target = glm::vec3(0.0f, 0.0f, 0.0f);
  camera.nearPlane = 0.5f;
  camera.farPlane = 60.0f;
  glm::vec3 forward = glm::normalize(camera.target - camera.eye);
  // Centre 1.2 m ahead, radius 1.0: the sphere spans 0.2..2.2 m along the view, across the near
  // plane at 0.5 m, with the camera outside it.
  glm::vec3 centre = camera.eye + forward * 1.2f;
  s.lights = {{centre, 1.0f, glm::vec3(0.3f, 0.6f, 1.0f), 6.0f, 1.0f}};
  REQUIRE(glm::length(camera.eye - centre) > 1.0f);
  Comparison c = renderAndCompare(s, settingsFor(camera, render::Target::Final), 2);
  CHECK(c.pixelsOver == 0);
}

TEST_CASE("spheres of every metallic and roughness match the reference") {
  scene::Scene s = floorScene();
  s.meshes.push_back(scene::makeSphere(48, 24));
  for (int i = 0; i < 4; ++i) {
    float m = i / 3.0f;
    s.materials.push_back({"sphere", glm::vec3(0.9f, 0.6f, 0.3f), m, 0.2f + 0.25f * i});
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(-2.4f + 1.6f * i, 0.6f, 0.0f));
    s.instances.push_back({1, uint32_t(s.materials.size() - 1), glm::scale(t, glm::vec3(0.6f))});
  }
  s.lights = {{glm::vec3(0.0f, 1.8f, 1.5f), 4.0f, glm::vec3(1.0f), 6.0f, 1.0f}};
  s.sun.intensity = 1.5f;
  Comparison c = renderAndCompare(s, settingsFor(lookingDownAtFloor(), render::Target::Final, 128, 80), 2);
  CHECK(c.pixelsOver <= c.pixels / 200);
}

TEST_CASE("unlit, ior and specular materials (glTF extensions) match the reference") {
  scene::Scene s = floorScene();
  s.meshes.push_back(scene::makeSphere(48, 24));
  // KHR_materials_unlit (a metal: reflection would show), ior 1.2 and 2.0, specular 0.3.
  for (int i = 0; i < 4; ++i) {
    scene::Material m{"sphere", glm::vec3(0.15f, 0.2f, 0.3f), 0.0f, 0.3f};
    if (i == 0) m.unlit = true, m.metallic = 1.0f, m.baseColor = glm::vec3(0.9f, 0.5f, 0.2f);
    if (i == 1) m.ior = 1.2f;
    if (i == 2) m.ior = 2.0f;
    if (i == 3) m.specular = 0.3f;
    s.materials.push_back(m);
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(-2.4f + 1.6f * i, 0.6f, 0.0f));
    s.instances.push_back({1, uint32_t(s.materials.size() - 1), glm::scale(t, glm::vec3(0.6f))});
  }
  s.lights = {{glm::vec3(0.0f, 1.8f, 1.5f), 4.0f, glm::vec3(1.0f), 6.0f, 1.0f}};
  s.sun.intensity = 1.5f;
  Comparison c = renderAndCompare(s, settingsFor(lookingDownAtFloor(), render::Target::Final, 128, 80), 2);
  CHECK(c.pixelsOver <= c.pixels / 200);
}

TEST_CASE("clear coat and sheen materials (glTF extensions) match the reference") {
  scene::Scene s = floorScene();
  s.meshes.push_back(scene::makeSphere(48, 24));
  // KHR_materials_clearcoat (a smooth full coat on a dark rough dielectric, a half coat on a rough
  // metal), KHR_materials_sheen (a pink sheen on dark cloth; sheen under a coat), and the last
  // drawn by the forward pass (BLEND at alpha 1, one-sided: the reference ignores alpha, so it
  // compares the forward pass's layers too).
  for (int i = 0; i < 5; ++i) {
    scene::Material m{"sphere", glm::vec3(0.2f, 0.05f, 0.06f), 0.0f, 0.7f};
    if (i == 0) m.clearcoat = 1.0f, m.clearcoatRoughness = 0.15f;
    if (i == 1) m.clearcoat = 0.5f, m.clearcoatRoughness = 0.4f, m.metallic = 1.0f,
                m.baseColor = glm::vec3(0.9f, 0.7f, 0.3f);
    if (i == 2) m.sheenColor = glm::vec3(1.0f, 0.4f, 0.6f), m.sheenRoughness = 0.3f;
    if (i >= 3) m.sheenColor = glm::vec3(0.3f, 0.5f, 1.0f), m.sheenRoughness = 0.6f,
                m.clearcoat = 0.7f, m.clearcoatRoughness = 0.25f;
    if (i == 4) m.alphaMode = scene::AlphaMode::blend, m.doubleSided = false;
    s.materials.push_back(m);
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(-3.2f + 1.6f * i, 0.6f, 0.0f));
    s.instances.push_back({1, uint32_t(s.materials.size() - 1), glm::scale(t, glm::vec3(0.6f))});
  }
  s.lights = {{glm::vec3(0.0f, 1.8f, 1.5f), 4.0f, glm::vec3(1.0f), 6.0f, 1.0f}};
  s.sun.intensity = 1.5f;
  s.sun.direction = glm::normalize(glm::vec3(0.4f, -0.5f, -0.6f));  // from behind the camera's left
  for (render::Technique technique :
       {render::Technique::Volumes, render::Technique::Tiled, render::Technique::Clustered}) {
    for (render::EnvironmentMode mode :
         {render::EnvironmentMode::None, render::EnvironmentMode::Sky}) {
      CAPTURE(render::techniqueName(technique));
      CAPTURE(int(mode));
      render::FrameSettings f = settingsFor(lookingDownAtFloor(), render::Target::Final, 144, 80);
      f.technique = technique;
      f.environment.mode = mode;
      Comparison c = renderAndCompare(s, f, 2);
      CHECK(c.pixelsOver <= c.pixels / 200);
    }
  }
  // The layers show: without them the reference differs on much of the spheres.
  scene::Scene bare = s;
  for (scene::Material& m : bare.materials) m.clearcoat = 0.0f, m.sheenColor = glm::vec3(0.0f);
  const render::FrameSettings f = settingsFor(lookingDownAtFloor(), render::Target::Final, 144, 80);
  const Comparison layers =
      compare(render::renderReference(s, render::FrameSettings(f).takeLightingFrom(s)),
              render::renderReference(bare, render::FrameSettings(f).takeLightingFrom(bare)), 8);
  MESSAGE("the layers change " << layers.pixelsOver << " pixels by more than 8/255");
  CHECK(layers.pixelsOver > 300);
}

TEST_CASE("normal target equals the analytic normal: floor (0,1,0) and a tilted plane") {
  scene::Scene s = floorScene();
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  render::Frame frame = gpu.render(settingsFor(lookingDownAtFloor(), render::Target::Normal));
  // (0,1,0) * 0.5 + 0.5 = (0.5, 1, 0.5) -> bytes (128, 255, 128); the sky (no geometry) is black.
  auto isBackground = [](const uint8_t* px) { return px[0] == 0 && px[1] == 0 && px[2] == 0; };
  size_t wrong = 0, floor = 0;
  for (size_t p = 0; p < frame.rgba.size(); p += 4) {
    if (isBackground(&frame.rgba[p])) continue;
    ++floor;
    if (std::abs(frame.rgba[p] - 128) > 1 || frame.rgba[p + 1] != 255 || std::abs(frame.rgba[p + 2] - 128) > 1) ++wrong;
  }
  CHECK(wrong == 0);
  CHECK(floor > frame.rgba.size() / 4 * 3 / 4);

  // A plane tilted 30 degrees about z: normal (-sin 30, cos 30, 0).
  scene::Scene tilted = s;
  tilted.instances[0].transform =
      glm::rotate(glm::mat4(1.0f), glm::radians(30.0f), glm::vec3(0, 0, 1)) * s.instances[0].transform;
  gpu.setScene(tilted);
  scene::Camera camera = lookingDownAtFloor();
  camera.eye = glm::vec3(0.0f, 6.0f, 6.0f);
  frame = gpu.render(settingsFor(camera, render::Target::Normal));
  glm::vec3 expected = glm::vec3(-0.5f, std::sqrt(3.0f) / 2.0f, 0.0f) * 0.5f + 0.5f;
  wrong = 0;
  floor = 0;
  for (size_t p = 0; p < frame.rgba.size(); p += 4) {
    if (isBackground(&frame.rgba[p])) continue;
    ++floor;
    for (int ch = 0; ch < 3; ++ch) {
      if (std::abs(frame.rgba[p + ch] - std::round(expected[ch] * 255.0f)) > 1) ++wrong;
    }
  }
  CHECK(wrong == 0);
  CHECK(floor > frame.rgba.size() / 4 * 3 / 4);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("depth target equals the analytic linear depth of the floor") {
  scene::Scene s = floorScene();
  scene::Camera camera = lookingDownAtFloor();
  render::FrameSettings f = settingsFor(camera, render::Target::Depth);
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  render::Frame frame = gpu.render(f);
  // Per pixel: intersect the view ray with y = 0 and take the distance along the view axis.
  glm::mat4 inverse = glm::inverse(scene::projectionMatrix(camera, float(f.width) / f.height) *
                                    scene::viewMatrix(camera));
  glm::vec3 forward = glm::normalize(camera.target - camera.eye);
  size_t wrong = 0, background = 0;
  for (uint32_t y = 0; y < f.height; ++y) {
    for (uint32_t x = 0; x < f.width; ++x) {
      glm::vec4 ndc((x + 0.5f) / f.width * 2 - 1, (y + 0.5f) / f.height * 2 - 1, 1.0f, 1.0f);
      glm::vec4 far = inverse * ndc;
      glm::vec3 dir = glm::normalize(glm::vec3(far) / far.w - camera.eye);
      float expected = 1.0f;
      if (dir.y < 0.0f) {
        float t = -camera.eye.y / dir.y;
        float viewDepth = t * glm::dot(dir, forward);
        glm::vec3 hit = camera.eye + dir * t;
        if (std::abs(hit.x) <= 20.0f && std::abs(hit.z) <= 20.0f && viewDepth < camera.farPlane) {
          expected = (viewDepth - camera.nearPlane) / (camera.farPlane - camera.nearPlane);
        }
      }
      if (expected == 1.0f) ++background;
      int got = frame.rgba[(size_t(y) * f.width + x) * 4];
      if (std::abs(got - int(std::round(expected * 255.0f))) > 1) ++wrong;
    }
  }
  CHECK(wrong == 0);
  CHECK(background > 0);  // the horizon is in view: both floor and sky were checked
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("every target of every view matches the reference on a small scene") {
  scene::Scene s = floorScene();
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"cube", glm::vec3(0.2f, 0.7f, 0.3f), 0.8f, 0.3f});
  s.instances.push_back({1, 1, glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.5f, 0.0f))});
  s.lights = {{glm::vec3(1.0f, 1.0f, 1.0f), 3.0f, glm::vec3(1.0f, 0.5f, 0.2f), 5.0f, 1.0f}};
  for (render::Target target : {render::Target::Final, render::Target::Albedo, render::Target::Normal,
                                render::Target::Position, render::Target::Uv, render::Target::Metallic,
                                render::Target::Roughness, render::Target::Depth}) {
    Comparison c = renderAndCompare(s, settingsFor(lookingDownAtFloor(), target), 2);
    CHECK(c.pixelsOver <= c.pixels / 200);
  }
}

TEST_CASE("light-volumes view tints exactly the pixels inside some light's sphere") {
  scene::Scene s = floorScene();
  s.lights = {{glm::vec3(0.0f, 0.2f, 0.0f), 1.5f, glm::vec3(1.0f, 0.0f, 0.0f), 5.0f, 1.0f}};
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  render::FrameSettings f = settingsFor(lookingDownAtFloor(), render::Target::LightVolumes);
  render::Frame volumes = gpu.render(f);
  f.target = render::Target::Final;
  render::Frame final = gpu.render(f);
  // Outside the sphere the view is the final image halved; inside, red is added on top.
  size_t tinted = 0;
  for (size_t p = 0; p < final.rgba.size(); p += 4) {
    int halfRed = int(std::round(final.rgba[p] / 255.0f * 0.5f * 255.0f));
    if (volumes.rgba[p] > halfRed + 10) ++tinted;
  }
  CHECK(tinted > 20);
  CHECK(tinted < final.rgba.size() / 4 / 2);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// A light at the eye or on a view ray puts L along V, where H = normalize(V + L) is V itself and
// V.H may round past 1: GLSL's pow(1 - V.H, 5) of a negative base is undefined (NaN on GPUs).
// Checked on raw HDR output in every technique, and the reference (whose pow gives NaN where GLSL's
// is undefined) must agree without throwing.
TEST_CASE("a light at the eye and lights on view rays: no NaN or Inf in any technique") {
  scene::Scene s = floorScene();
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"metal", glm::vec3(0.9f, 0.8f, 0.5f), 1.0f, 0.2f});
  s.instances.push_back({1, 1, glm::translate(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, 0.0f))});
  const scene::Camera camera = lookingDownAtFloor();
  const glm::vec3 view = camera.target - camera.eye;
  s.lights = {{camera.eye, 12.0f, glm::vec3(1.0f), 4.0f, 1.0f}};  // a headlight
  for (float t : {0.25f, 0.5f, 0.8f}) {
    s.lights.push_back({camera.eye + t * view, 6.0f, glm::vec3(1.0f, 0.9f, 0.7f), 3.0f, 1.0f});
  }
  for (render::Technique technique :
       {render::Technique::Volumes, render::Technique::Tiled, render::Technique::Clustered}) {
    CAPTURE(render::techniqueName(technique));
    render::FrameSettings f = settingsFor(camera, render::Target::Final);
    f.technique = technique;
    Comparison c = renderAndCompare(s, f, 2);  // also checks the raw final output is finite
    CHECK(c.pixelsOver <= c.pixels / 200);
  }
}

// ---- Light markers (shaders/marker_splat.comp, marker_resolve.comp) ----

namespace {

// Pixels whose colour differs by more than 2/255 between two 8-bit images.
size_t changedPixels(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  return compare(a, b, 2).pixelsOver;
}

// Where a world point lands, in pixels (y down), as the GPU projects it.
glm::vec2 pixelOf(const scene::Camera& camera, uint32_t w, uint32_t h, glm::vec3 point) {
  glm::vec4 clip = scene::projectionMatrix(camera, float(w) / float(h)) * scene::viewMatrix(camera) *
                   glm::vec4(point, 1.0f);
  glm::vec2 ndc = glm::vec2(clip) / clip.w;
  return (ndc * 0.5f + 0.5f) * glm::vec2(w, h);
}

}  // namespace

TEST_CASE("markers: at 100,000 lights' density at least 80% of final shows the scene, in every technique") {
  // 1280x720 with 100,000 lights is 9.216 pixels per light; markers are sized and thinned by that
  // density alone (shaders/markers.glsl), so 320x180 with 6,250 lights is the same picture's worth
  // of markers at a sixteenth of lavapipe's time. The built-in scene, from its default view.
  Gpu& gpu = sharedGpu();
  const scene::Scene s = scene::makeBuiltinScene(6250, 3);
  gpu.setScene(s);
  for (render::Technique t : {render::Technique::Volumes, render::Technique::Tiled, render::Technique::Clustered}) {
    render::FrameSettings f = settingsFor(s.camera, render::Target::Final, 320, 180);
    f.technique = t;
    render::Frame off = gpu.render(f);
    f.markers = true;
    render::Frame on = gpu.render(f);
    const size_t pixels = size_t(f.width) * f.height;
    const size_t changed = changedPixels(on.rgba, off.rgba);
    MESSAGE(render::techniqueName(t) << ": markers changed " << changed << " of " << pixels << " pixels ("
                                     << 100.0 * double(changed) / double(pixels) << "%)");
    CHECK(changed * 5 <= pixels);         // >= 80% of the picture is the scene
    CHECK(changed >= pixels / 100);       // and the markers are there to see
    CHECK(gpu.context->validationMessages.load() == 0);
  }
}

TEST_CASE("coarser meshes where they differ by under half a pixel: the built-in scene at 160x90") {
  // A stream's interactive frames (FrameSettings::geometryErrorPixels): the spheres drawn with
  // fewer triangles must be the same picture but for silhouette pixels, and their depth must
  // show they were drawn (flat facets sit inside the curved mesh), by at most their error.
  Gpu& gpu = sharedGpu();
  const scene::Scene s = scene::makeBuiltinScene(64, 3);
  gpu.setScene(s);
  render::FrameSettings f = settingsFor(s.camera, render::Target::Final, 160, 90);
  const render::Frame full = gpu.render(f);
  f.geometryErrorPixels = 0.5f;
  const render::Frame coarse = gpu.render(f);
  const Comparison c = compare(coarse.rgba, full.rgba, 8);
  MESSAGE("coarse meshes: " << c.pixelsOver << " of " << c.pixels << " pixels over 8/255, max "
                            << c.maxDifference);
  CHECK(c.pixelsOver <= c.pixels / 50);

  f.target = render::Target::Depth;
  f.raw = true;
  const render::Frame coarseDepth = gpu.render(f);
  f.geometryErrorPixels = 0.0f;
  const render::Frame fullDepth = gpu.render(f);
  REQUIRE(coarseDepth.data.size() == fullDepth.data.size());
  // The largest error the chosen versions may have, in metres: the 16x8 sphere's (0.038 of the
  // radius, 0.45 m), with room for the view angle.
  const float radius = 0.45f;
  const float bound = 3.0f * 0.04f * radius;
  size_t deeper = 0, beyond = 0;
  for (size_t i = 0; i < coarseDepth.data.size(); i += 4) {
    const float d = std::abs(coarseDepth.data[i] - fullDepth.data[i]);
    if (d > 1e-4f && d <= bound) ++deeper;
    if (d > bound) ++beyond;  // a silhouette pixel: sphere in one, floor behind in the other
  }
  const size_t pixels = size_t(f.width) * f.height;
  MESSAGE("depth: " << deeper << " pixels moved by the coarser facets, " << beyond << " silhouette pixels");
  CHECK(deeper >= pixels / 100);  // the coarse versions were drawn
  CHECK(beyond <= pixels / 50);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// The full-size case of the test above; skipped in CTest for time (about 3 minutes on lavapipe:
// 100,000 lights lit twice at 1280x720). Run it with --no-skip -tc="markers: 100,000*".
// Measured when added: 25,800 of 921,600 pixels changed (2.8%).
TEST_CASE("markers: 100,000 lights at 1280x720 leave at least 80% of final to the scene" * doctest::skip()) {
  Gpu& gpu = sharedGpu();
  const scene::Scene s = scene::makeBuiltinScene(100000, 5);
  gpu.setScene(s);
  render::FrameSettings f = settingsFor(s.camera, render::Target::Final, 1280, 720);
  f.technique = render::Technique::Clustered;
  render::Frame off = gpu.render(f);
  f.markers = true;
  render::Frame on = gpu.render(f);
  const size_t pixels = size_t(f.width) * f.height;
  const size_t changed = changedPixels(on.rgba, off.rgba);
  MESSAGE("markers changed " << changed << " of " << pixels << " pixels ("
                             << 100.0 * double(changed) / double(pixels) << "%)");
  CHECK(changed * 5 <= pixels);
  CHECK(changed >= pixels / 100);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("markers: a few pixels across, round, in the light's hue, hidden behind a wall") {
  Gpu& gpu = sharedGpu();
  scene::Scene s = floorScene();
  // A wall 1 m tall across x in [-0.5, 3], 1 m in front of the second light.
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"wall", glm::vec3(0.3f), 0.0f, 0.8f});
  glm::mat4 wall = glm::translate(glm::mat4(1.0f), glm::vec3(1.25f, 0.5f, -1.0f));
  s.instances.push_back({1, 1, glm::scale(wall, glm::vec3(3.5f, 1.0f, 0.2f))});
  const glm::vec3 open(-1.5f, 0.4f, 0.0f);     // in view, red
  const glm::vec3 hidden(1.25f, 0.4f, -2.0f);  // behind the wall, green
  s.lights = {{open, 0.3f, glm::vec3(1.0f, 0.1f, 0.05f), 2.0f, 1.0f},
              {hidden, 0.3f, glm::vec3(0.1f, 1.0f, 0.1f), 2.0f, 1.0f}};
  gpu.setScene(s);
  const scene::Camera camera = lookingDownAtFloor();
  const uint32_t w = 192, h = 128;
  for (render::Technique t : {render::Technique::Volumes, render::Technique::Tiled, render::Technique::Clustered}) {
    CAPTURE(render::techniqueName(t));
    render::FrameSettings f = settingsFor(camera, render::Target::Final, w, h);
    f.technique = t;
    render::Frame off = gpu.render(f);
    f.markers = true;
    render::Frame on = gpu.render(f);
    const glm::vec2 at = pixelOf(camera, w, h, open);
    const glm::vec2 behind = pixelOf(camera, w, h, hidden);
    size_t near = 0, far = 0, behindWall = 0;
    float farthest = 0.0f;
    for (uint32_t y = 0; y < h; ++y) {
      for (uint32_t x = 0; x < w; ++x) {
        size_t i = (size_t(y) * w + x) * 4;
        int worst = 0;
        for (int ch = 0; ch < 3; ++ch) worst = std::max(worst, std::abs(int(on.rgba[i + ch]) - int(off.rgba[i + ch])));
        if (worst <= 2) continue;
        glm::vec2 centre(x + 0.5f, y + 0.5f);
        float d = glm::length(centre - at);
        farthest = std::max(farthest, d);
        (d <= 3.6f ? near : far) += 1;
        if (glm::length(centre - behind) <= 6.0f) ++behindWall;
      }
    }
    MESSAGE(render::techniqueName(t) << ": " << near << " marker pixels within 3.6 px of the open light, "
                                     << far << " elsewhere, " << behindWall << " around the hidden one");
    CHECK(near >= 5);          // visible, a few pixels across
    CHECK(near <= 41);         // bounded: pi * 3.6^2 = 40.7
    CHECK(far == 0);           // nothing beyond the radius, nothing from the hidden light
    CHECK(behindWall == 0);
    // The centre pixel is the light's hue: red well above green and blue.
    size_t c = (size_t(at.y) * w + size_t(at.x)) * 4;
    CHECK(int(on.rgba[c]) > int(on.rgba[c + 1]) + 40);
    CHECK(int(on.rgba[c]) > int(on.rgba[c + 2]) + 40);
    CHECK(gpu.context->validationMessages.load() == 0);
  }
}
