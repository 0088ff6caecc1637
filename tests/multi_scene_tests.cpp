// Several scenes on one renderer (one per session): each renders its own content; edits of lights
// and materials upload in place and change the image as the C++ reference predicts; destroying a
// scene frees its memory; sun, ambient and background come with the frame; overflowing cluster
// lists grow. On lavapipe with validation on; any validation message fails.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <turbojpeg.h>

#include "encode/jpeg.h"
#include "gpu_test_support.h"
#include "image_compare.h"
#include "render/reference.h"
#include "render/renderer.h"
#include "scene/light_generator.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using Gpu = test::GpuSuite;

Gpu& sharedGpu() {
  static Gpu gpu = test::createGpuSuite();
  return gpu;
}

using test::maxDifference;
using test::pixelsOver;

scene::Scene floorScene(glm::vec3 colour) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.materials.push_back({"floor", colour, 0.0f, 0.6f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(40.0f, 1.0f, 40.0f))});
  s.sun.direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.2f));
  s.sun.intensity = 0.4f;
  s.ambient = glm::vec3(0.02f);
  return s;
}

// The floor under `count` generated lights of radius 0.3-1.2 above it: a frame heavy enough to
// split when the slice is made small.
scene::Scene floorWithLights(uint32_t count) {
  scene::Scene s = floorScene(glm::vec3(0.5f, 0.5f, 0.45f));
  scene::LightGeneration g;
  g.count = count;
  g.bounds = {glm::vec3(-4.0f, 0.1f, -5.0f), glm::vec3(4.0f, 1.0f, 2.0f)};
  g.minRadius = 0.3f;
  g.maxRadius = 1.2f;
  s.lights = scene::generateLights(g);
  return s;
}

// A warm floor lit by two lights.
scene::Scene sceneA() {
  scene::Scene s = floorScene(glm::vec3(0.6f, 0.4f, 0.3f));
  s.lights = {{glm::vec3(-1.0f, 0.5f, 0.0f), 2.5f, glm::vec3(1.0f, 0.3f, 0.1f), 6.0f, 1.0f},
              {glm::vec3(1.5f, 0.3f, -1.0f), 1.5f, glm::vec3(0.2f, 0.5f, 1.0f), 8.0f, 4.0f}};
  return s;
}

// A cool floor with a block on it, three other lights and a brighter, lower sun: nothing in
// common with A but the floor mesh.
scene::Scene sceneB() {
  scene::Scene s = floorScene(glm::vec3(0.3f, 0.45f, 0.6f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"block", glm::vec3(0.9f, 0.8f, 0.2f), 0.7f, 0.3f});
  s.instances.push_back({1, 1, glm::translate(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, -0.5f))});
  s.lights = {{glm::vec3(0.0f, 0.4f, 1.0f), 2.0f, glm::vec3(0.2f, 1.0f, 0.3f), 5.0f, 1.0f},
              {glm::vec3(-2.0f, 1.0f, -2.0f), 3.0f, glm::vec3(1.0f, 1.0f, 1.0f), 3.0f, 0.5f},
              {glm::vec3(2.0f, 0.2f, 1.5f), 1.2f, glm::vec3(1.0f, 0.0f, 1.0f), 9.0f, 2.0f}};
  s.sun.direction = glm::normalize(glm::vec3(0.6f, -0.5f, 0.1f));
  s.sun.intensity = 1.2f;
  s.sun.color = glm::vec3(1.0f, 0.7f, 0.5f);
  s.ambient = glm::vec3(0.05f, 0.04f, 0.03f);
  s.background = glm::vec3(0.1f, 0.2f, 0.4f);
  return s;
}

render::FrameSettings settingsFor(const scene::Scene& s, render::Technique technique =
                                                             render::Technique::Clustered) {
  render::FrameSettings f;
  f.width = 64;
  f.height = 48;
  f.camera.eye = glm::vec3(0.0f, 3.0f, 5.0f);
  f.camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  f.camera.fovYDegrees = 60.0f;
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 100.0f;
  f.markers = false;
  f.antialias = render::Antialias::None;  // compared with the reference, which does not anti-alias
  f.technique = technique;
  f.takeLightingFrom(s);
  return f;
}

// Scene B's block has silhouettes: pixel centres on an edge may fall either way (see
// gpu_image_tests.cpp), so up to 0.5% of pixels may differ more than 2/255.
void checkMatchesReference(const render::Frame& frame, const scene::Scene& s,
                           const render::FrameSettings& f) {
  std::vector<uint8_t> reference = render::renderReference(s, f);
  size_t over = pixelsOver(frame.rgba, reference, 2);
  MESSAGE("vs reference: max difference " << maxDifference(frame.rgba, reference) << "/255, "
                                          << over << " pixels over 2");
  CHECK(over <= frame.rgba.size() / 4 / 200);
}

scene::PointLight light(glm::vec3 position, float radius, glm::vec3 colour, float intensity) {
  return {position, radius, colour, intensity, 1.0f};
}

}  // namespace

TEST_CASE("two scenes render their own content side by side") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene a = sceneA(), b = sceneB();
  render::SceneId idA = r.createScene(a);
  render::Frame aAlone = r.render(idA, settingsFor(a));  // before B exists

  render::SceneId idB = r.createScene(b);
  CHECK(idB != idA);
  CHECK(r.lightCount(idA) == 2);
  CHECK(r.lightCount(idB) == 3);
  // Interleaved, as sessions' frames arrive.
  for (int round = 0; round < 2; ++round) {
    render::Frame fa = r.render(idA, settingsFor(a));
    render::Frame fb = r.render(idB, settingsFor(b));
    CAPTURE(round);
    CHECK(fa.rgba == aAlone.rgba);  // B's presence changes nothing of A
    CHECK(fa.lightCount == 2);
    CHECK(fb.lightCount == 3);
    CHECK(fa.sceneBytes == r.sceneBytes(idA));
    CHECK(fb.sceneBytes == r.sceneBytes(idB));
    checkMatchesReference(fa, a, settingsFor(a));
    checkMatchesReference(fb, b, settingsFor(b));
    // The two images have little in common: most pixels differ clearly.
    CHECK(pixelsOver(fa.rgba, fb.rgba, 10) > fa.rgba.size() / 4 * 3 / 4);
  }
  // Every technique draws the scene asked for.
  for (render::Technique t : {render::Technique::Volumes, render::Technique::Tiled}) {
    checkMatchesReference(r.render(idB, settingsFor(b, t)), b, settingsFor(b, t));
  }
  r.destroyScene(idA);
  r.destroyScene(idB);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("destroyScene frees the scene's memory at once and leaves the others rendering") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene a = sceneA();
  render::SceneId idA = r.createScene(a);
  render::Frame before = r.render(idA, settingsFor(a));

  scene::Scene big = sceneB();
  scene::LightGeneration g;
  g.count = 200000;
  g.bounds.min = glm::vec3(-10.0f, 0.1f, -10.0f);
  g.bounds.max = glm::vec3(10.0f, 1.0f, 10.0f);
  big.lights = scene::generateLights(g);
  const uint64_t withoutBig = r.gpuMemoryBytes();
  render::SceneId idBig = r.createScene(big);
  const uint64_t withBig = r.gpuMemoryBytes();
  const uint64_t bigBytes = r.sceneBytes(idBig);
  MESSAGE("renderer " << withoutBig / 1024 << " KiB, + a 200,000-light scene of " << bigBytes / 1024
                      << " KiB");
  CHECK(bigBytes >= 2 * 200000 * 32);  // current positions and origins
  CHECK(withBig - withoutBig == bigBytes);

  r.destroyScene(idBig);
  CHECK(r.gpuMemoryBytes() == withoutBig);
  CHECK_FALSE(r.hasScene(idBig));
  CHECK_THROWS_AS(r.render(idBig, settingsFor(big)), std::invalid_argument);
  CHECK_THROWS_AS(r.destroyScene(idBig), std::invalid_argument);
  CHECK_THROWS_AS(r.updateLights(idBig, {}), std::invalid_argument);
  CHECK_THROWS_AS(r.replaceScene(idBig, a), std::invalid_argument);
  CHECK(r.render(idA, settingsFor(a)).rgba == before.rgba);

  // A new scene never gets a destroyed scene's id.
  render::SceneId next = r.createScene(a);
  CHECK(next != idBig);
  CHECK(next != idA);
  r.destroyScene(next);
  r.destroyScene(idA);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("updating one light changes the image as the reference predicts") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneA();
  s.lights.push_back(light(glm::vec3(0.0f, 0.3f, 2.0f), 1.0f, glm::vec3(1.0f), 4.0f));
  render::SceneId id = r.createScene(s);
  render::Frame before = r.render(id, settingsFor(s));
  checkMatchesReference(before, s, settingsFor(s));

  // Light 1 moves next to the camera's view centre, turns green and brighter.
  s.lights[1] = light(glm::vec3(0.3f, 0.4f, -0.5f), 2.0f, glm::vec3(0.1f, 1.0f, 0.2f), 10.0f);
  r.updateLights(id, {3, {{1, s.lights[1]}}});
  CHECK(r.lightCount(id) == 3);
  render::Frame after = r.render(id, settingsFor(s));
  checkMatchesReference(after, s, settingsFor(s));
  CHECK(pixelsOver(before.rgba, after.rgba, 8) > 50);

  // Removing light 0 of 3: the last moves into its slot and the count drops.
  s.lights[0] = s.lights[2];
  s.lights.pop_back();
  r.updateLights(id, {2, {{0, s.lights[0]}}});
  checkMatchesReference(r.render(id, settingsFor(s)), s, settingsFor(s));

  // Several writes of one index: the last wins.
  s.lights[0].color = glm::vec3(1.0f, 0.0f, 0.0f);
  scene::PointLight overwritten = s.lights[0];
  overwritten.color = glm::vec3(0.0f, 0.0f, 1.0f);
  r.updateLights(id, {2, {{0, overwritten}, {0, s.lights[0]}}});
  checkMatchesReference(r.render(id, settingsFor(s)), s, settingsFor(s));
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("an edit after animated frames applies to the lights' origins too") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneA();
  render::SceneId id = r.createScene(s);
  render::FrameSettings animated = settingsFor(s);
  animated.animate = true;
  animated.time = 1.3;
  render::Frame moving = r.render(id, animated);
  CHECK(moving.lightCount == 2);
  s.lights[0] = light(glm::vec3(0.5f, 0.3f, 0.5f), 3.0f, glm::vec3(0.9f, 0.9f, 0.1f), 7.0f);
  r.updateLights(id, {2, {{0, s.lights[0]}}});
  // A still frame puts every light back at its origin: light 0's new one, light 1's old one.
  checkMatchesReference(r.render(id, settingsFor(s)), s, settingsFor(s));
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("lights grow past the buffers' capacity, shrink, and bad updates change nothing") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneA();  // the buffers start exactly full: 2 lights
  render::SceneId id = r.createScene(s);
  const uint64_t startBytes = r.sceneBytes(id);

  scene::LightGeneration g;
  g.count = 400;
  g.seed = 5;
  g.bounds.min = glm::vec3(-6.0f, 0.05f, -8.0f);
  g.bounds.max = glm::vec3(6.0f, 0.8f, 3.0f);
  g.minRadius = 0.3f;
  g.maxRadius = 1.2f;
  const std::vector<scene::PointLight> extra = scene::generateLights(g);
  // Appended in uneven batches, as POST .../lights requests would: 2 -> 3 -> 70 -> 402.
  size_t added = 0;
  for (size_t batch : {size_t(1), size_t(67), size_t(332)}) {
    render::LightUpdate update;
    update.count = uint32_t(s.lights.size() + batch);
    for (size_t i = 0; i < batch; ++i) {
      update.writes.push_back({uint32_t(s.lights.size() + i), extra[added + i]});
    }
    for (size_t i = 0; i < batch; ++i) s.lights.push_back(extra[added + i]);
    added += batch;
    r.updateLights(id, update);
    CHECK(r.lightCount(id) == s.lights.size());
  }
  MESSAGE("scene bytes: " << startBytes << " with 2 lights, " << r.sceneBytes(id) << " with 402");
  CHECK(r.sceneBytes(id) >= startBytes);
  for (render::Technique t : {render::Technique::Clustered, render::Technique::Volumes}) {
    render::Frame frame = r.render(id, settingsFor(s, t));
    CHECK(frame.lightCount == 402);
    checkMatchesReference(frame, s, settingsFor(s, t));
  }

  // Shrinking needs no writes: the first 10 stay.
  s.lights.resize(10);
  r.updateLights(id, {10, {}});
  render::Frame ten = r.render(id, settingsFor(s));
  checkMatchesReference(ten, s, settingsFor(s));

  // A new slot left unwritten, or a write past the count: refused, nothing changes.
  CHECK_THROWS_WITH_AS(r.updateLights(id, {12, {{10, extra[0]}}}),
                       "new light 11 (of 12) is not written", std::invalid_argument);
  CHECK_THROWS_WITH_AS(r.updateLights(id, {10, {{10, extra[0]}}}),
                       "light write at index 10 is past the new light count 10",
                       std::invalid_argument);
  CHECK(r.lightCount(id) == 10);
  CHECK(r.render(id, settingsFor(s)).rgba == ten.rgba);

  // Growing from an empty scene.
  scene::Scene empty = sceneB();
  empty.lights.clear();
  render::SceneId emptyId = r.createScene(empty);
  CHECK(r.lightCount(emptyId) == 0);
  empty.lights = {extra[3]};
  r.updateLights(emptyId, {1, {{0, extra[3]}}});
  checkMatchesReference(r.render(emptyId, settingsFor(empty)), empty, settingsFor(empty));
  r.destroyScene(emptyId);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("updateMaterials changes exactly the material's pixels") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneB();
  render::SceneId id = r.createScene(s);
  render::Frame before = r.render(id, settingsFor(s));

  // The block turns red and rough; the floor is untouched.
  s.materials[1].baseColor = glm::vec3(0.9f, 0.05f, 0.05f);
  s.materials[1].metallic = 0.0f;
  s.materials[1].roughness = 0.9f;
  r.updateMaterials(id, {{1, s.materials[1]}});
  render::Frame after = r.render(id, settingsFor(s));
  checkMatchesReference(after, s, settingsFor(s));
  size_t changed = pixelsOver(before.rgba, after.rgba, 8);
  MESSAGE(changed << " of " << after.rgba.size() / 4 << " pixels changed");
  CHECK(changed > 30);                            // the block's pixels
  CHECK(changed < after.rgba.size() / 4 / 2);     // not the floor's

  CHECK_THROWS_WITH_AS(r.updateMaterials(id, {{2, s.materials[0]}}),
                       "material 2 is past the scene's 2 materials", std::invalid_argument);
  CHECK(r.render(id, settingsFor(s)).rgba == after.rgba);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// The emissive target is written only while some material emits (MYRIAD_GBUFFER_EMISSIVE): an
// edit that makes one emit must light it up, one that stops it must give the frame of before.
TEST_CASE("emission follows material edits both ways, though the emissive target is optional") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneB();
  for (scene::Material& m : s.materials) m.emissive = glm::vec3(0.0f);
  render::SceneId id = r.createScene(s);
  render::Frame dark = r.render(id, settingsFor(s));

  s.materials[1].emissive = glm::vec3(0.0f, 2.0f, 0.0f);
  s.materials[1].emissiveStrength = 1.0f;
  r.updateMaterials(id, {{1, s.materials[1]}});
  render::Frame glowing = r.render(id, settingsFor(s));
  checkMatchesReference(glowing, s, settingsFor(s));
  size_t greener = 0;
  for (size_t i = 0; i < glowing.rgba.size(); i += 4) {
    if (glowing.rgba[i + 1] > dark.rgba[i + 1] + 40) ++greener;
  }
  MESSAGE(greener << " pixels glow green");
  CHECK(greener > 30);

  s.materials[1].emissive = glm::vec3(0.0f);
  r.updateMaterials(id, {{1, s.materials[1]}});
  CHECK(r.render(id, settingsFor(s)).rgba == dark.rgba);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// The layers target (clear coat, sheen) is written only while some material has one
// (MYRIAD_GBUFFER_LAYERS, decided per frame from SceneBuffers::layered): an edit that gives a
// scene without layers a coat or a sheen (PATCH .../materials) must draw it, in every technique,
// as the reference does; one that takes it away must give the frame of before.
TEST_CASE("a clear coat or sheen given by a material edit is drawn; taken away, the frame of before") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneB();
  for (const scene::Material& m : s.materials) REQUIRE_FALSE(m.layered());
  render::SceneId id = r.createScene(s);
  for (render::Technique technique :
       {render::Technique::Clustered, render::Technique::Tiled, render::Technique::Volumes}) {
    CAPTURE(render::techniqueName(technique));
    const render::FrameSettings f = settingsFor(s, technique);
    const render::Frame bare = r.render(id, f);
    const std::vector<uint8_t> bareReference = render::renderReference(s, f);
    // The pixels the edit changes, on the GPU and in the reference, by more than 2/255.
    auto changedBy = [&](const render::Frame& edited) {
      const size_t gpuChanged = pixelsOver(bare.rgba, edited.rgba, 2);
      const size_t referenceChanged = pixelsOver(bareReference, render::renderReference(s, f), 2);
      MESSAGE(gpuChanged << " of " << edited.rgba.size() / 4 << " pixels changed, "
                         << referenceChanged << " in the reference");
      CHECK(gpuChanged + 3 >= referenceChanged);  // the same pixels, but up to 3 on silhouettes
      CHECK(gpuChanged <= referenceChanged + 3);
      return gpuChanged;
    };

    s.materials[1].clearcoat = 1.0f;
    s.materials[1].clearcoatRoughness = 0.1f;
    r.updateMaterials(id, {{1, s.materials[1]}});
    const render::Frame coated = r.render(id, f);
    checkMatchesReference(coated, s, f);
    const size_t coat = changedBy(coated);
    CHECK(coat >= 25);                            // the block's lit faces
    CHECK(coat < coated.rgba.size() / 4 / 2);     // not the floor's

    s.materials[1].clearcoat = 0.0f;
    s.materials[1].sheenColor = glm::vec3(1.0f, 0.4f, 0.6f);
    s.materials[1].sheenRoughness = 0.5f;
    r.updateMaterials(id, {{1, s.materials[1]}});
    const render::Frame sheened = r.render(id, f);
    checkMatchesReference(sheened, s, f);
    const size_t sheen = changedBy(sheened);
    CHECK(sheen >= 25);
    CHECK(sheen < sheened.rgba.size() / 4 / 2);

    s.materials[1].sheenColor = glm::vec3(0.0f);
    r.updateMaterials(id, {{1, s.materials[1]}});
    CHECK(r.render(id, f).rgba == bare.rgba);
  }
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("sun, ambient and background come from the frame settings, not the scene") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene s = sceneB();
  render::SceneId id = r.createScene(s);
  render::FrameSettings authored = settingsFor(s);
  render::FrameSettings changed = authored;
  changed.sun.direction = glm::vec3(-0.5f, -0.4f, -0.2f);  // not normalized: the renderer does it
  changed.sun.intensity = 3.0f;
  changed.sun.color = glm::vec3(0.6f, 0.8f, 1.0f);
  changed.ambient = glm::vec3(0.1f, 0.0f, 0.0f);
  changed.background = glm::vec3(0.0f, 0.5f, 0.0f);
  render::Frame one = r.render(id, authored);
  render::Frame two = r.render(id, changed);
  checkMatchesReference(one, s, authored);
  checkMatchesReference(two, s, changed);
  CHECK(pixelsOver(one.rgba, two.rgba, 10) > one.rgba.size() / 4 * 3 / 4);
  // Back again: nothing of the other settings stayed behind.
  CHECK(r.render(id, authored).rgba == one.rgba);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("replaceScene swaps the content under the same id") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene a = sceneA(), b = sceneB();
  render::SceneId id = r.createScene(a);
  render::Frame first = r.render(id, settingsFor(a));
  r.replaceScene(id, b);
  CHECK(r.lightCount(id) == 3);
  checkMatchesReference(r.render(id, settingsFor(b)), b, settingsFor(b));
  // A broken scene is refused and the old one stays.
  scene::Scene broken = a;
  broken.instances[0].material = 7;
  CHECK_THROWS_AS(r.replaceScene(id, broken), std::invalid_argument);
  CHECK_THROWS_AS(r.createScene(broken), std::invalid_argument);
  checkMatchesReference(r.render(id, settingsFor(b)), b, settingsFor(b));
  r.replaceScene(id, a);
  CHECK(r.render(id, settingsFor(a)).rgba == first.rgba);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("overflowing cluster lists are reported at the limit and grow below it") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  // 600 faint lights of radius 60 reach every cluster with geometry: 600 references per active
  // cluster, far more than 4,096 in all.
  constexpr uint32_t kLights = 600;
  scene::Scene s = floorScene(glm::vec3(0.6f));
  for (uint32_t i = 0; i < kLights; ++i) {
    s.lights.push_back(light(glm::vec3(0.01f * i - 3.0f, 2.0f, 0.0f), 60.0f, glm::vec3(0.006f), 1.0f));
  }
  render::SceneId id = r.createScene(s);
  render::FrameSettings f = settingsFor(s);
  f.width = 128;
  f.height = 80;
  constexpr uint64_t kSmall = 4096 * sizeof(uint32_t);

  // Lists capped at 4,096 references cannot hold them, nor grow: the overflow is reported.
  r.limitListMemory(kSmall);
  render::Frame limited = r.render(id, f);
  const render::CullingReport& c = limited.culling;
  const uint64_t needed = uint64_t(c.activeClusters) * kLights;
  MESSAGE("limited: " << c.activeClusters << " active clusters, " << c.listEntries << " kept, "
                      << c.clusterLightsDropped << " dropped, capacity " << c.listCapacity);
  CHECK(c.listCapacity == 4096);
  CHECK(c.listEntries <= 4096);
  CHECK(c.clusterLightsDropped == needed - c.listEntries);
  CHECK(c.overflowed());
  CHECK_FALSE(c.listsGrew);

  // Starting at 4,096 below the device's limit: the frame overflows, the lists grow to 1.25x what
  // it needed, and the frame is rendered again, complete.
  r.limitListMemory(0, kSmall);
  render::Frame grown = r.render(id, f);
  const render::CullingReport& g = grown.culling;
  MESSAGE("grown: " << g.listEntries << " references, capacity " << g.listCapacity << ", "
                    << g.listBytes << " list bytes");
  CHECK(g.listsGrew);
  CHECK_FALSE(g.overflowed());
  CHECK(g.listEntries == needed);
  CHECK(g.listCapacity == uint32_t(std::ceil(double(needed) * 1.25)));
  // Every light is there: the tiled technique (its tile lists hold these 600) agrees.
  render::FrameSettings tiled = f;
  tiled.technique = render::Technique::Tiled;
  render::Frame tiledFrame = r.render(id, tiled);
  REQUIRE_FALSE(tiledFrame.culling.overflowed());
  CHECK(maxDifference(grown.rgba, tiledFrame.rgba) <= 1);
  CHECK(pixelsOver(limited.rgba, grown.rgba, 2) > 0);  // the limited frame really missed lights

  // The next frame keeps the capacity: no overflow, no second render, the same pixels (up to the
  // order in which a list's lights were summed, which follows the GPU's atomics).
  render::Frame next = r.render(id, f);
  CHECK_FALSE(next.culling.overflowed());
  CHECK_FALSE(next.culling.listsGrew);
  CHECK(next.culling.listCapacity == g.listCapacity);
  CHECK(maxDifference(next.rgba, grown.rgba) <= 1);

  // Split, the same: the split frame's own lists (started at 4,096 again) overflow, and once
  // its lists are built it reads the overflow, grows them and builds them again before any tile
  // is shaded from them.
  r.limitListMemory(0, kSmall);
  r.setSliceMilliseconds(1.0);
  REQUIRE(r.shouldSplit(id, f));
  std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(id, f);
  std::optional<render::Frame> splitFrame;
  while (!(splitFrame = r.continueSplit(*split))) {
  }
  split.reset();
  r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
  MESSAGE("split: " << splitFrame->submissions << " submissions, capacity "
                    << splitFrame->culling.listCapacity);
  CHECK(splitFrame->culling.listsGrew);
  CHECK_FALSE(splitFrame->culling.overflowed());
  CHECK(splitFrame->culling.listEntries == needed);
  CHECK(maxDifference(splitFrame->rgba, grown.rgba) <= 1);
  r.limitListMemory(0);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a random run of light edits leaves the GPU matching the scene the edits describe") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene s = sceneA();
  render::SceneId id = r.createScene(s);
  uint64_t state = 12345;  // xorshift: the same run every time
  auto next = [&state](uint32_t below) {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return uint32_t(state % below);
  };
  auto randomLight = [&] {
    glm::vec3 p(float(next(1000)) / 100.0f - 5.0f, 0.05f + float(next(100)) / 100.0f,
                float(next(1000)) / 100.0f - 7.0f);
    glm::vec3 c(float(next(100)) / 100.0f, float(next(100)) / 100.0f, float(next(100)) / 100.0f);
    return light(p, 0.3f + float(next(150)) / 100.0f, c, 1.0f + float(next(500)) / 100.0f);
  };
  size_t checks = 0;
  for (int step = 1; step <= 120; ++step) {
    render::LightUpdate update;
    const auto n = uint32_t(s.lights.size());
    switch (next(5)) {
      case 0: {  // append 1..80
        uint32_t k = 1 + next(80);
        for (uint32_t i = 0; i < k; ++i) {
          s.lights.push_back(randomLight());
          update.writes.push_back({n + i, s.lights.back()});
        }
        break;
      }
      case 1:  // remove one: the last moves into its slot
        if (n > 0) {
          uint32_t i = next(n);
          s.lights[i] = s.lights.back();
          s.lights.pop_back();
          if (i < n - 1) update.writes.push_back({i, s.lights[i]});
        }
        break;
      case 2:  // change a few
        for (uint32_t k = 0; n > 0 && k < 1 + next(6); ++k) {
          uint32_t i = next(n);
          s.lights[i] = randomLight();
          update.writes.push_back({i, s.lights[i]});
        }
        break;
      case 3:  // truncate, sometimes to nothing
        s.lights.resize(next(5) == 0 ? 0 : n / 2);
        break;
      case 4: {  // an animated frame in between: the edits must reach the origins too
        render::FrameSettings f = settingsFor(s);
        f.animate = true;
        f.time = step * 0.1;
        r.render(id, f);
        break;
      }
    }
    update.count = uint32_t(s.lights.size());
    r.updateLights(id, update);
    REQUIRE(r.lightCount(id) == s.lights.size());
    if (step % 30 == 0) {
      CAPTURE(step);
      checkMatchesReference(r.render(id, settingsFor(s)), s, settingsFor(s));
      ++checks;
    }
  }
  CHECK(checks == 4);
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a split frame equals the whole frame, with other scenes' frames between its parts") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene heavy = floorWithLights(3000);
  const scene::Scene other = sceneB();
  const render::SceneId heavyId = r.createScene(heavy);
  const render::SceneId otherId = r.createScene(other);
  const render::FrameSettings heavySettings = settingsFor(heavy, render::Technique::Volumes);
  render::FrameSettings otherSettings = settingsFor(other);
  otherSettings.width = 40;  // other targets' size: the split frame's own must not change
  otherSettings.height = 30;

  // The whole frame measures what a light costs; with a tiny slice the frame must now split.
  const render::Frame whole = r.render(heavyId, heavySettings);
  const render::Frame otherAlone = r.render(otherId, otherSettings);
  CHECK(whole.submissions == 1);
  // A slice of 5 ms: the lights (0.05-0.09 ms each on lavapipe) take a few dozen ranges.
  r.setSliceMilliseconds(5.0);
  CHECK(r.shouldSplit(heavyId, heavySettings));

  std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(heavyId, heavySettings);
  CHECK(r.splitBusy());
  CHECK_THROWS_AS(r.beginSplit(heavyId, heavySettings), std::logic_error);
  std::optional<render::Frame> done;
  int between = 0;
  while (!(done = r.continueSplit(*split))) {
    // What the render thread does between the parts: other scenes' whole frames.
    render::Frame o = r.render(otherId, otherSettings);
    CHECK(o.rgba == otherAlone.rgba);
    ++between;
  }
  split.reset();
  CHECK_FALSE(r.splitBusy());
  MESSAGE("3,000 lights split into " << done->submissions << " submissions, " << between
                                     << " other frames between them");
  // The passes before the lighting, the sun, the lights in ranges, the passes after it.
  CHECK(done->submissions >= 8);
  CHECK(between == int(done->submissions) - 2);  // beginSplit ran the first, the last returned it
  CHECK(done->rgba == whole.rgba);  // the same draws in the same order, split
  CHECK(done->lightCount == 3000);
  double lightsMs = -1.0;
  for (const render::PassTiming& p : done->passes) {
    if (p.name == "lights") lightsMs = p.milliseconds;
  }
  CHECK(lightsMs >= 0.0);  // one "lights" pass, summed over the ranges

  // A split frame dropped half way frees the split targets for the next one, which completes.
  split = r.beginSplit(heavyId, heavySettings);
  CHECK(!r.continueSplit(*split).has_value());
  split.reset();
  split = r.beginSplit(heavyId, heavySettings);
  while (!(done = r.continueSplit(*split))) {
  }
  split.reset();
  CHECK(done->rgba == whole.rgba);

  r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
  r.releaseFrameMemory();
  r.destroyScene(heavyId);
  r.destroyScene(otherId);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("split tiled and clustered frames equal their whole frames, counters included") {
  // The compute techniques split too: tiled in ranges of tiles, clustered its passes over the
  // lights in ranges and its shading in ranges of tiles. The split frame keeps its own lists and
  // counters (LightingTechnique::splitInstance): whole frames of other scenes between its parts
  // (the same technique, other lights, another size) leave them alone.
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene heavy = floorWithLights(600);
  const scene::Scene other = sceneB();
  const render::SceneId heavyId = r.createScene(heavy);
  const render::SceneId otherId = r.createScene(other);
  for (const render::Technique technique : {render::Technique::Tiled, render::Technique::Clustered}) {
    CAPTURE(render::techniqueName(technique));
    render::FrameSettings heavySettings = settingsFor(heavy, technique);
    heavySettings.width = 96;
    heavySettings.height = 64;
    heavySettings.antialias = render::Antialias::Fxaa;  // the anti-aliasing step too
    render::FrameSettings otherSettings = settingsFor(other, technique);
    otherSettings.width = 40;
    otherSettings.height = 30;
    const render::Frame whole = r.render(heavyId, heavySettings);
    const render::Frame otherAlone = r.render(otherId, otherSettings);
    r.setSliceMilliseconds(1.0);  // about every tile, light group and final-pass range its own
    REQUIRE(r.shouldSplit(heavyId, heavySettings));
    std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(heavyId, heavySettings);
    std::optional<render::Frame> done;
    int between = 0;
    while (!(done = r.continueSplit(*split))) {
      if (between % 7 == 0) {
        const render::Frame o = r.render(otherId, otherSettings);
        CHECK(o.rgba == otherAlone.rgba);
      }
      ++between;
    }
    split.reset();
    r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
    MESSAGE(render::techniqueName(technique) << ": " << done->submissions << " submissions");
    CHECK(done->submissions > 10);
    // The same lights reach the same pixels; the order a pixel sums them in may differ (the
    // clustered lists are filled by atomics), by a rounding step of the 8-bit output at most.
    CHECK(maxDifference(done->rgba, whole.rgba) <= 1);
    CHECK(done->culling.listEntries == whole.culling.listEntries);
    CHECK(done->culling.mostLightsInList == whole.culling.mostLightsInList);
    CHECK(done->culling.clusterLightsDropped == whole.culling.clusterLightsDropped);
    CHECK(done->culling.tileLightsDropped == whole.culling.tileLightsDropped);
  }
  r.releaseFrameMemory();
  r.destroyScene(heavyId);
  r.destroyScene(otherId);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a split frame over the frame budget stops with FrameBudgetError") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  scene::Scene heavy = floorScene(glm::vec3(0.5f));
  scene::LightGeneration g;
  g.count = 2000;
  g.bounds = {glm::vec3(-4.0f, 0.1f, -5.0f), glm::vec3(4.0f, 1.0f, 2.0f)};
  heavy.lights = scene::generateLights(g);
  const render::SceneId id = r.createScene(heavy);
  const render::FrameSettings settings = settingsFor(heavy, render::Technique::Volumes);
  r.setSliceMilliseconds(0.001);
  r.setFrameBudgetMilliseconds(0.001);
  std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(id, settings);
  std::string message;
  try {
    r.continueSplit(*split);
  } catch (const render::FrameBudgetError& e) {
    message = e.what();
    CHECK(e.budgetMs == doctest::Approx(0.001));
    CHECK(e.elapsedMs > e.budgetMs);
  }
  MESSAGE(message);
  CHECK(message.find("over the budget") != std::string::npos);
  split.reset();
  // Without a budget the next split frame completes.
  r.setFrameBudgetMilliseconds(0.0);
  r.setSliceMilliseconds(1.0);
  split = r.beginSplit(id, settings);
  std::optional<render::Frame> done;
  while (!(done = r.continueSplit(*split))) {
  }
  split.reset();
  r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
  CHECK(done->lightCount == 2000);
  r.releaseFrameMemory();
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("frames in flight each keep their own pixels, counters and animation time") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene a = sceneA();
  const scene::Scene b = sceneB();
  const render::SceneId idA = r.createScene(a);
  const render::SceneId idB = r.createScene(b);
  // Animated: every frame of a scene moves that scene's lights (on the GPU) to its own time, so a
  // frame recorded behind another of the same scene must not see the other's positions.
  auto at = [](const scene::Scene& s, double time,
               render::Technique technique = render::Technique::Clustered) {
    render::FrameSettings f = settingsFor(s, technique);
    f.animate = true;
    f.time = time;
    return f;
  };
  struct Job {
    render::SceneId id;
    render::FrameSettings settings;
  };
  // Two scenes in turn and back to back, and a technique change (the renderer waits for the
  // frames in flight before the tiled frame: its lists differ).
  const std::vector<Job> jobs = {{idA, at(a, 0.0)},  {idB, at(b, 0.5)},
                                 {idA, at(a, 1.0)},  {idA, at(a, 2.0)},
                                 {idB, at(b, 1.5)},  {idB, at(b, 3.0, render::Technique::Tiled)},
                                 {idA, at(a, 4.0)},  {idB, at(b, 5.0)}};
  std::vector<render::Frame> serial;
  for (const Job& job : jobs) serial.push_back(r.render(job.id, job.settings));
  CHECK(pixelsOver(serial[2].rgba, serial[3].rgba, 2) > 0);  // the lights moved between them

  // Three in flight: a frame is begun while up to two others are on the GPU, and finished in
  // the order begun; with overlap, frames of another scene start without waiting for them.
  r.setFramesInFlight(3);
  CHECK(r.framesInFlight() == 3);
  for (bool overlap : {false, true}) {
    CAPTURE(overlap);
    r.setOverlap(overlap);
    std::deque<uint32_t> slots;
    std::vector<render::Frame> pipelined;
    size_t mostInFlight = 0;
    for (const Job& job : jobs) {
      if (!r.canBegin()) {
        pipelined.push_back(r.finishFrame(slots.front()));
        slots.pop_front();
      }
      slots.push_back(r.beginFrame(job.id, job.settings));
      mostInFlight = std::max(mostInFlight, slots.size());
    }
    CHECK_THROWS_AS(r.beginFrame(idA, jobs[0].settings), std::logic_error);  // every slot busy
    CHECK_THROWS_AS(r.setFramesInFlight(1), std::logic_error);
    while (!slots.empty()) {
      pipelined.push_back(r.finishFrame(slots.front()));
      slots.pop_front();
    }
    CHECK(mostInFlight == 3);
    REQUIRE(pipelined.size() == serial.size());
    for (size_t i = 0; i < jobs.size(); ++i) {
      CAPTURE(i);
      // Up to the order a list's lights were summed in (the GPU's atomics).
      CHECK(maxDifference(pipelined[i].rgba, serial[i].rgba) <= 1);
      CHECK(pipelined[i].culling.listEntries == serial[i].culling.listEntries);
      CHECK(pipelined[i].culling.activeClusters == serial[i].culling.activeClusters);
      CHECK(pipelined[i].culling.mostLightsInList == serial[i].culling.mostLightsInList);
      CHECK(pipelined[i].lightCount == serial[i].lightCount);
      CHECK(pipelined[i].technique == serial[i].technique);
    }
  }
  r.setOverlap(false);

  // A frame in flight when its scene is destroyed keeps what it rendered; edits wait for it.
  const uint32_t slot = r.beginFrame(idA, jobs[0].settings);
  r.updateLights(idB, {3, {{0, b.lights[0]}}});
  r.destroyScene(idA);
  const render::Frame orphan = r.finishFrame(slot);
  CHECK(maxDifference(orphan.rgba, serial[0].rgba) <= 1);
  CHECK(orphan.lightCount == 2);
  CHECK_THROWS_AS(r.finishFrame(slot), std::logic_error);  // no longer in flight
  r.setFramesInFlight(1);
  r.destroyScene(idB);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a still between smaller frames keeps its slot's targets and sun map; the idle trim keeps them") {
  // A stream's interactive frames are smaller than its still (a quarter of each side, no sun
  // shadows) and come between its stills: with two slots each size keeps its own targets, and
  // the still's slot its sun map, instead of the still making 1280x720 targets anew (docs/
  // performance.md "The drag's still"). The idle trim (RenderThread, kIdleKeepBytes) keeps the
  // last frame's when they are small enough.
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene b = sceneB();
  const render::SceneId id = r.createScene(b);
  render::FrameSettings still = settingsFor(b);
  still.shadows.sun = true;
  still.shadows.mapSize = 512;
  still.borrowPixels = true;
  render::FrameSettings moving = settingsFor(b);
  moving.width = still.width / 4;
  moving.height = still.height / 4;
  moving.borrowPixels = true;
  auto drewShadow = [](const render::Frame& f) {
    return std::any_of(f.passes.begin(), f.passes.end(),
                       [](const render::PassTiming& p) { return p.name == "shadow"; });
  };
  auto bytes = [](const render::Frame& f) {
    return std::vector<uint8_t>(f.pixels().begin(), f.pixels().end());
  };
  r.releaseFrameMemory();
  r.setFramesInFlight(2);
  const render::Frame first = r.render(id, still);
  CHECK(first.madeTargets);
  CHECK(drewShadow(first));
  for (int i = 0; i < 3; ++i) {
    CAPTURE(i);
    const render::Frame small = r.render(id, moving);
    CHECK(small.madeTargets == (i == 0));  // its own slot, made once
    CHECK_FALSE(drewShadow(small));
    const render::Frame again = r.render(id, still);
    CHECK_FALSE(again.madeTargets);
    CHECK_FALSE(drewShadow(again));
    CHECK(maxDifference(bytes(again), bytes(first)) <= 1);  // up to the GPU's atomics' order
  }
  // The interactive frames' scale changes: their slot's targets are made again (nearest in
  // size), the still's stay.
  render::FrameSettings larger = moving;
  larger.width = still.width / 2;
  larger.height = still.height / 2;
  CHECK(r.render(id, larger).madeTargets);
  CHECK_FALSE(r.render(id, larger).madeTargets);
  const render::Frame afterScale = r.render(id, still);
  CHECK_FALSE(afterScale.madeTargets);
  CHECK_FALSE(drewShadow(afterScale));
  // One slot: every change of size makes the targets again (what two slots avoid).
  r.setFramesInFlight(1);
  CHECK(r.render(id, moving).madeTargets);
  CHECK(r.render(id, still).madeTargets);

  // Idle: the last frame's slot stays when it fits keepBytes, else everything goes.
  r.setFramesInFlight(2);
  r.render(id, still);
  const uint64_t held = r.gpuMemoryBytes();
  r.releaseFrameMemory(64ull << 20);
  CHECK(r.gpuMemoryBytes() <= held);
  const render::Frame afterKeep = r.render(id, still);
  CHECK_FALSE(afterKeep.madeTargets);
  CHECK_FALSE(drewShadow(afterKeep));
  r.releaseFrameMemory(1);  // too small to keep anything
  const render::Frame afterTrim = r.render(id, still);
  CHECK(afterTrim.madeTargets);
  CHECK(drewShadow(afterTrim));
  CHECK(maxDifference(bytes(afterTrim), bytes(first)) <= 1);
  r.setFramesInFlight(1);
  r.releaseFrameMemory();
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("borrowed pixels: frames encoded in place equal copied ones; the memory comes back") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene a = sceneA();
  const render::SceneId id = r.createScene(a);
  render::FrameSettings copied = settingsFor(a);
  render::FrameSettings borrowing = copied;
  borrowing.borrowPixels = true;
  const render::Frame reference = r.render(id, copied);
  CHECK(!reference.borrowed);
  CHECK(reference.pixels().size() == reference.rgba.size());
  r.releaseFrameMemory();
  const uint64_t before = r.gpuMemoryBytes();

  // Frames in flight, each read back into a pooled buffer of its own and lent out with it; the
  // render thread copies nothing (FrameTimes::copyMs ~ 0; the copy path took a memcpy).
  r.setFramesInFlight(3);
  std::vector<render::Frame> held;
  std::deque<uint32_t> slots;
  for (int i = 0; i < 6; ++i) {
    if (!r.canBegin()) {
      held.push_back(r.finishFrame(slots.front()));
      slots.pop_front();
    }
    slots.push_back(r.beginFrame(id, borrowing));
  }
  while (!slots.empty()) {
    held.push_back(r.finishFrame(slots.front()));
    slots.pop_front();
  }
  for (const render::Frame& f : held) {
    REQUIRE(f.borrowed);
    CHECK(f.rgba.empty());
    CHECK(f.pixels().size() == size_t(copied.width) * copied.height * 4);
    CHECK(std::equal(f.pixels().begin(), f.pixels().end(), reference.rgba.begin()));
    CHECK(f.times.recordMs > 0.0);
    if (gpu.context->info.timestampsSupported) CHECK(f.times.gpuMs > 0.0);
  }
  // Six lent out at once: six buffers; the memory stays while they are held.
  CHECK(r.gpuMemoryBytes() >= before + 6 * reference.rgba.size());
  r.releaseFrameMemory();
  CHECK(r.gpuMemoryBytes() >= 6 * reference.rgba.size());
  held.clear();  // encoded: given back from whichever thread
  r.releaseFrameMemory();
  CHECK(r.gpuMemoryBytes() <= before);

  // More held than the pool lends: the rest are copied out on the render thread, still right.
  std::vector<render::Frame> many;
  for (int i = 0; i < 20; ++i) many.push_back(r.render(id, borrowing));
  size_t lent = 0;
  for (const render::Frame& f : many) {
    lent += f.borrowed ? 1 : 0;
    CHECK(std::equal(f.pixels().begin(), f.pixels().end(), reference.rgba.begin()));
  }
  CHECK(lent == 16);
  CHECK(!many.back().borrowed);
  CHECK(many.back().rgba == reference.rgba);
  // Given back from another thread while the renderer renders.
  std::thread encoder([&] { many.clear(); });
  encoder.join();
  CHECK(r.render(id, borrowing).borrowed);
  r.setFramesInFlight(1);
  r.releaseFrameMemory();
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}

namespace {

// A JPEG decoded to RGB (libturbojpeg), or empty when it does not decode.
std::vector<uint8_t> decodeJpegRgb(const std::vector<uint8_t>& jpeg, uint32_t width, uint32_t height) {
  tjhandle handle = tjInitDecompress();
  REQUIRE(handle != nullptr);
  std::vector<uint8_t> rgb(size_t(width) * height * 3);
  const bool ok = tjDecompress2(handle, jpeg.data(), static_cast<unsigned long>(jpeg.size()),
                                rgb.data(), int(width), 0, int(height), TJPF_RGB, 0) == 0;
  tjDestroy(handle);
  if (!ok) rgb.clear();
  return rgb;
}

struct RgbError {
  double psnr = 0.0;  // dB over the three channels
  int maxError = 0;
};

RgbError compareToRgba(const std::vector<uint8_t>& rgb, const std::vector<uint8_t>& rgba) {
  RgbError e;
  double squares = 0.0;
  const size_t pixels = rgba.size() / 4;
  for (size_t i = 0; i < pixels; ++i) {
    for (size_t c = 0; c < 3; ++c) {
      const int d = int(rgb[i * 3 + c]) - int(rgba[i * 4 + c]);
      squares += double(d) * d;
      e.maxError = std::max(e.maxError, std::abs(d));
    }
  }
  const double mse = squares / double(pixels * 3);
  e.psnr = mse > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
  return e;
}

}  // namespace

TEST_CASE("YCbCr frames: the GPU's 4:2:0 planes encode the same picture as the RGBA path") {
  Gpu& gpu = sharedGpu();
  render::Renderer& r = *gpu.renderer;
  const scene::Scene b = sceneB();
  const render::SceneId id = r.createScene(b);
  // Odd sizes (padding to 8 x 2), and one large enough to be encoded in strips.
  for (const auto& [width, height] : {std::pair{101u, 77u}, std::pair{1280u, 720u}}) {
    CAPTURE(width);
    render::FrameSettings rgbaSettings = settingsFor(b);
    rgbaSettings.width = width;
    rgbaSettings.height = height;
    rgbaSettings.antialias = render::Antialias::Fxaa;
    rgbaSettings.markers = true;
    render::FrameSettings yuvSettings = rgbaSettings;
    yuvSettings.yuv420 = true;
    yuvSettings.borrowPixels = true;
    const render::Frame rgba = r.render(id, rgbaSettings);
    const render::Frame yuv = r.render(id, yuvSettings);
    REQUIRE(!rgba.yuv420);
    REQUIRE(yuv.yuv420);
    const render::Yuv420Layout l = render::yuv420Layout(width, height);
    REQUIRE(yuv.pixels().size() == l.bytes());
    CHECK(l.bytes() * 2 < rgba.rgba.size());  // 1.5 bytes a pixel (with padding) against 4
    const std::span<const uint8_t> planes = yuv.pixels();

    // The planes against JFIF's conversion done here in doubles: Y of each pixel, Cb and Cr of
    // each 2 x 2 block's mean, edges repeated. Rounding may differ by one level.
    int yError = 0, chromaError = 0;
    auto at = [&](uint32_t x, uint32_t y, int c) {
      return double(rgba.rgba[(size_t(std::min(y, height - 1)) * width + std::min(x, width - 1)) * 4 + c]);
    };
    for (uint32_t y = 0; y < height; ++y) {
      for (uint32_t x = 0; x < width; ++x) {
        const double luma = 0.299 * at(x, y, 0) + 0.587 * at(x, y, 1) + 0.114 * at(x, y, 2);
        yError = std::max(yError, std::abs(int(planes[size_t(y) * l.yStride + x]) - int(std::lround(luma))));
      }
    }
    for (uint32_t y = 0; y < l.rows / 2; ++y) {
      for (uint32_t x = 0; x < (width + 1) / 2; ++x) {
        double m[3] = {0, 0, 0};
        for (int c = 0; c < 3; ++c) {
          m[c] = (at(2 * x, 2 * y, c) + at(2 * x + 1, 2 * y, c) + at(2 * x, 2 * y + 1, c) +
                  at(2 * x + 1, 2 * y + 1, c)) / 4.0;
        }
        const double cb = -0.168736 * m[0] - 0.331264 * m[1] + 0.5 * m[2] + 128.0;
        const double cr = 0.5 * m[0] - 0.418688 * m[1] - 0.081312 * m[2] + 128.0;
        const size_t i = l.yBytes() + size_t(y) * l.chromaStride + x;
        chromaError = std::max(chromaError, std::abs(int(planes[i]) - int(std::lround(cb))));
        chromaError = std::max(chromaError, std::abs(int(planes[i + l.chromaBytes()]) - int(std::lround(cr))));
      }
    }
    CHECK(yError <= 1);
    CHECK(chromaError <= 1);

    // Both encoded at quality 80 (4:2:0) and decoded: the YCbCr path is as close to the RGBA
    // picture (what PNG carries) as libjpeg's own conversion is.
    const std::vector<uint8_t> fromRgba = encode::encodeJpeg(rgba.rgba, width, height, 80, 4);
    const std::vector<uint8_t> fromPlanes = encode::encodeJpegYuv420(
        planes.subspan(0, l.yBytes()), planes.subspan(l.yBytes(), l.chromaBytes()),
        planes.subspan(l.yBytes() + l.chromaBytes(), l.chromaBytes()), width, height, l.yStride,
        l.chromaStride, 80, 4);
    const std::vector<uint8_t> decodedRgba = decodeJpegRgb(fromRgba, width, height);
    const std::vector<uint8_t> decodedPlanes = decodeJpegRgb(fromPlanes, width, height);
    REQUIRE(!decodedRgba.empty());
    REQUIRE(!decodedPlanes.empty());
    const RgbError viaRgba = compareToRgba(decodedRgba, rgba.rgba);
    const RgbError viaPlanes = compareToRgba(decodedPlanes, rgba.rgba);
    MESSAGE(width << "x" << height << ": PSNR against the RGBA picture " << viaPlanes.psnr
                  << " dB from planes (max error " << viaPlanes.maxError << "), " << viaRgba.psnr
                  << " dB from RGBA (max error " << viaRgba.maxError << "); " << fromPlanes.size()
                  << " against " << fromRgba.size() << " bytes");
    CHECK(viaPlanes.psnr >= 30.0);
    CHECK(viaPlanes.psnr >= viaRgba.psnr - 0.5);
    CHECK(viaPlanes.maxError <= viaRgba.maxError + 8);
  }
  r.releaseFrameMemory();
  r.destroyScene(id);
  CHECK(gpu.context->validationMessages.load() == 0);
}
