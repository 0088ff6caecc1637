// The three lighting techniques (volumes, tiled, clustered) on lavapipe with validation on:
// the same image within 1/255, matching the C++ reference; exact light counts; reported overflow;
// a million animated lights.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "image_compare.h"
#include "render/reference.h"
#include "shared_types.h"
#include "render/renderer.h"
#include "scene/builtin_scene.h"
#include "scene/light_generator.h"
#include "scene/primitives.h"

using namespace myriad;
using render::Technique;

namespace {

// Every technique the renderer has (render/techniques/registry.cpp): a new one is held to the
// same image without an edit here.
const std::vector<Technique> kTechniques = render::allTechniques();

using Gpu = test::GpuSuite;

Gpu& sharedGpu() {
  static Gpu gpu = test::createGpuSuite();
  return gpu;
}

using test::maxDifference;

// A floor with a few boxes, lit by `count` lights just above it; lights' reach scales so about
// the same number of them covers each point whatever the count.
scene::Scene litFloor(uint32_t count, uint64_t seed) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.6f), 0.0f, 0.7f});
  s.materials.push_back({"box", glm::vec3(0.8f, 0.5f, 0.3f), 0.5f, 0.35f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(20.0f, 1.0f, 20.0f))});
  for (int i = 0; i < 3; ++i) {
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(-3.0f + 3.0f * i, 0.5f, -1.0f - i));
    s.instances.push_back({1, 1, t});
  }
  s.sun.intensity = 0.3f;
  scene::LightGeneration g;
  g.count = count;
  g.seed = seed;
  g.bounds.min = glm::vec3(-10.0f, 0.05f, -10.0f);
  g.bounds.max = glm::vec3(10.0f, 1.2f, 6.0f);
  float reach = count <= 1 ? 6.0f : std::max(0.25f, 6.0f / std::cbrt(float(count)));
  g.minRadius = 0.5f * reach;
  g.maxRadius = 1.5f * reach;
  g.minIntensity = 1.0f;
  g.maxIntensity = 3.0f;
  s.lights = scene::generateLights(g);
  return s;
}

render::FrameSettings frameSettings(Technique technique, uint32_t w = 96, uint32_t h = 64) {
  render::FrameSettings f;
  f.width = w;
  f.height = h;
  f.camera.eye = glm::vec3(0.0f, 4.0f, 8.0f);
  f.camera.target = glm::vec3(0.0f, 0.0f, -2.0f);
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 60.0f;
  f.markers = false;
  f.antialias = render::Antialias::None;  // compared with the reference, which does not anti-alias
  f.technique = technique;
  return f;
}

// A second suite made with the suites' knobs plus `tunes` (each a --tune key=value,
// render/tuning.h): the same renderer taking the technique's other way.
Gpu suiteWith(std::initializer_list<const char*> tunes) {
  render::Tuning tuning = test::suiteTuning();
  for (const char* tune : tunes) render::applyTune(tuning, tune);
  return test::createGpuSuite(tuning);
}

// A frame and the same frame's raw light-count target (lights reaching each pixel).
struct ImageAndCounts {
  render::Frame image;
  render::Frame counts;
};

ImageAndCounts renderWithCounts(Gpu& gpu, render::FrameSettings f) {
  ImageAndCounts r;
  r.image = gpu.render(f);
  f.raw = true;
  f.target = render::Target::LightCount;
  r.counts = gpu.render(f);
  return r;
}

}  // namespace

TEST_CASE("tuning: the knobs resolve per device, and a device without subgroups keeps its paths") {
  // render/tuning.h: defaults that depend on the device are resolved once, from its properties.
  gpu::DeviceInfo gpuDevice;
  gpuDevice.computeSubgroupShuffle = true;
  gpuDevice.multiprocessors = 132;
  gpuDevice.maxComputeWorkGroupInvocations = gpuDevice.maxComputeWorkGroupSizeX = 1024;
  const render::Tuning onGpu = render::resolveTuning({}, gpuDevice);
  CHECK(onGpu.assign == render::AssignPath::Binned);
  CHECK(onGpu.shade == render::ShadePass::Subgroup);
  CHECK(onGpu.pointTest == 2u);
  CHECK(onGpu.assignGroups == 132u);
  CHECK(onGpu.assignGroupSize == 1024);

  gpu::DeviceInfo cpuDevice = gpuDevice;
  cpuDevice.isCpu = true;
  cpuDevice.multiprocessors = 0;
  cpuDevice.maxComputeWorkGroupInvocations = 512;
  const render::Tuning onCpu = render::resolveTuning({}, cpuDevice);
  CHECK(onCpu.assign == render::AssignPath::PerPair);
  CHECK(onCpu.shade == render::ShadePass::WholeWhenShort);
  CHECK(onCpu.pointTest == 0u);
  CHECK(onCpu.assignGroups == 128u);
  CHECK(onCpu.assignGroupSize == 512);  // halved to what the device runs

  // What --tune asked wins where the device can run it, not where it cannot.
  render::Tuning asked;
  render::applyTune(asked, "assign=binned");
  render::applyTune(asked, "shade=subgroup");
  render::applyTune(asked, "point-test=1");
  CHECK(render::resolveTuning(asked, cpuDevice).assign == render::AssignPath::Binned);
  CHECK(render::resolveTuning(asked, cpuDevice).pointTest == 1u);
  gpu::DeviceInfo noSubgroups = gpuDevice;
  noSubgroups.computeSubgroupShuffle = false;
  CHECK(render::resolveTuning(asked, noSubgroups).assign == render::AssignPath::PerPair);
  CHECK(render::resolveTuning(asked, noSubgroups).shade == render::ShadePass::Pixel);
}

TEST_CASE("volumes, tiled and clustered give the same image within 1/255, matching the reference") {
  Gpu& gpu = sharedGpu();
  for (uint32_t count : {1u, 100u, 10000u}) {
    scene::Scene s = litFloor(count, 7);
    gpu.setScene(s);
    std::vector<uint8_t> reference = render::renderReference(s, frameSettings(Technique::Clustered).takeLightingFrom(s));
    std::vector<std::vector<uint8_t>> images;
    for (Technique t : kTechniques) {
      render::Frame frame = gpu.render(frameSettings(t));
      CHECK_FALSE(frame.culling.overflowed());
      int vsReference = maxDifference(frame.rgba, reference);
      MESSAGE(count << " lights, " << render::techniqueName(t) << ": max difference from the reference "
                    << vsReference << "/255, longest list " << frame.culling.mostLightsInList);
      CHECK(vsReference <= 2);
      images.push_back(std::move(frame.rgba));
    }
    CAPTURE(count);
    REQUIRE(images.size() >= 3);
    for (size_t a = 0; a < images.size(); ++a) {
      for (size_t b = a + 1; b < images.size(); ++b) {
        CAPTURE(render::techniqueName(kTechniques[a]));
        CAPTURE(render::techniqueName(kTechniques[b]));
        CHECK(maxDifference(images[a], images[b]) <= 1);
      }
    }
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("awkward lights are right in every technique: tiny, huge, behind the camera, across near and far") {
  scene::Scene s = litFloor(0, 1);
  render::FrameSettings base = frameSettings(Technique::Clustered);
  glm::vec3 forward = glm::normalize(base.camera.target - base.camera.eye);
  s.lights = {
      {glm::vec3(0.5f, 0.02f, 0.0f), 0.03f, glm::vec3(1.0f), 50.0f, 1.0f},                 // tiny
      {glm::vec3(0.0f, 30.0f, 0.0f), 45.0f, glm::vec3(0.3f, 0.3f, 1.0f), 1.5f, 1.0f},     // huge
      {base.camera.eye - forward * 2.0f, 6.0f, glm::vec3(1.0f, 0.2f, 0.2f), 4.0f, 1.0f},  // behind
      {base.camera.eye + forward * 0.3f, 2.5f, glm::vec3(0.2f, 1.0f, 0.2f), 3.0f, 1.0f},  // camera inside
      {base.camera.eye + forward * 0.9f + glm::vec3(0, -1.2f, 0), 1.0f, glm::vec3(1.0f, 1.0f, 0.0f), 5.0f, 2.0f},
      {base.camera.eye + forward * 59.0f, 8.0f, glm::vec3(1.0f, 0.5f, 1.0f), 4.0f, 1.0f},  // across far
  };
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  std::vector<uint8_t> reference = render::renderReference(s, render::FrameSettings(base).takeLightingFrom(s));
  for (Technique t : kTechniques) {
    render::Frame frame = gpu.render(frameSettings(t));
    CAPTURE(render::techniqueName(t));
    CHECK(maxDifference(frame.rgba, reference) <= 2);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("light-count target is exact at sampled pixels with 200,000 lights") {
  Gpu& gpu = sharedGpu();
  scene::Scene s = litFloor(200000, 11);
  gpu.setScene(s);
  render::FrameSettings f = frameSettings(Technique::Clustered, 80, 56);
  f.raw = true;
  f.target = render::Target::Position;
  render::Frame positions = gpu.render(f);
  for (Technique t : {Technique::Clustered, Technique::Tiled, Technique::Volumes}) {
    f.technique = t;
    f.target = render::Target::LightCount;
    render::Frame counts = gpu.render(f);
    CAPTURE(render::techniqueName(t));
    // Tiled too: its tiles hold more lights than a list here, shaded a list at a time.
    CHECK_FALSE(counts.culling.overflowed());
    size_t sampled = 0, exact = 0, nonzero = 0;
    for (uint32_t y = 1; y < f.height; y += 5) {
      for (uint32_t x = 1; x < f.width; x += 5) {
        size_t i = (size_t(y) * f.width + x) * 4;
        glm::vec3 p(positions.data[i], positions.data[i + 1], positions.data[i + 2]);
        if (p == glm::vec3(0.0f)) continue;  // sky
        // Lights within a hair of the boundary may fall either way in float; count them apart.
        uint32_t inside = 0, boundary = 0;
        for (const scene::PointLight& l : s.lights) {
          glm::vec3 d = l.position - p;
          float dd = glm::dot(d, d), rr = l.radius * l.radius;
          if (std::abs(dd - rr) <= 1e-4f * rr) ++boundary;
          else if (dd < rr) ++inside;
        }
        uint32_t gpuCount = uint32_t(counts.data[i]);
        ++sampled;
        if (gpuCount >= inside && gpuCount <= inside + boundary) ++exact;
        if (gpuCount > 0) ++nonzero;
      }
    }
    MESSAGE(render::techniqueName(t) << ": " << exact << " of " << sampled << " sampled pixels exact, "
                                     << nonzero << " lit");
    CHECK(sampled > 100);
    CHECK(nonzero > sampled / 2);
    CHECK(exact == sampled);
  }
  // And the same picture: tiled's tiles (up to the most lights any tile had, well past a list of
  // MYRIAD_TILE_MAX_LIGHTS) shaded a list at a time give clustered's image.
  f.raw = false;
  f.target = render::Target::Final;
  f.technique = Technique::Clustered;
  const render::Frame clustered = gpu.render(f);
  f.technique = Technique::Tiled;
  const render::Frame tiled = gpu.render(f);
  MESSAGE("tiled: most lights in a tile " << tiled.culling.mostLightsInList << " (a list holds "
                                          << MYRIAD_TILE_MAX_LIGHTS << ")");
  CHECK(tiled.culling.mostLightsInList > MYRIAD_TILE_MAX_LIGHTS);
  CHECK_FALSE(tiled.culling.overflowed());
  CHECK(maxDifference(tiled.rgba, clustered.rgba) <= 2);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("binned and per-pair cluster assignment build the same lists and image") {
  // The clustered technique counts small lights per workgroup in shared memory on GPUs and with a
  // global atomic per light-cluster pair on CPU devices (techniques/clustered.cpp); a second
  // renderer made with --tune assign set to the other way must agree exactly.
  Gpu& gpu = sharedGpu();
  const bool cpu = gpu.context->info.isCpu;
  Gpu other = suiteWith({cpu ? "assign=binned" : "assign=atomic"});
  scene::Scene s = litFloor(20000, 7);
  gpu.setScene(s);
  other.setScene(s);
  render::FrameSettings f = frameSettings(Technique::Clustered, 160, 112);
  auto [a, countsA] = renderWithCounts(gpu, f);
  auto [b, countsB] = renderWithCounts(other, f);
  MESSAGE("20,000 lights: " << a.culling.listEntries << " references in " << a.culling.activeClusters
                            << " clusters, longest " << a.culling.mostLightsInList);
  // 18,277 references when lights were tested against the clusters' view boxes alone; 4,321
  // since they are also tested against the bounds of each cluster's points (stop 18).
  CHECK(a.culling.listEntries > 3000);
  CHECK_FALSE(a.culling.overflowed());
  CHECK(a.culling.listEntries == b.culling.listEntries);
  CHECK(a.culling.activeClusters == b.culling.activeClusters);
  CHECK(a.culling.mostLightsInList == b.culling.mostLightsInList);
  CHECK(countsA.data == countsB.data);  // every pixel's exact light count
  CHECK(maxDifference(a.rgba, b.rgba) <= 1);  // the same lights summed in another order
  CHECK(gpu.context->validationMessages.load() == 0);
  CHECK(other.context->validationMessages.load() == 0);
}

TEST_CASE("clustered: clusters marked in the compute G-buffer's resolve or by the pixel pass, the same lists") {
  // Where the G-buffer is made in compute, its resolve pass marks the clusters holding geometry
  // (techniques/clustered.cpp, visibility_resolve.comp); a renderer made with
  // --tune mark-in-gbuffer=off marks them from the same depth in the technique's own pixel pass.
  // Lists, active clusters and every pixel's count must agree exactly, frame after frame (the
  // marks are cleared by the frame that reads them).
  Gpu& gpu = sharedGpu();
  Gpu other = suiteWith({"mark-in-gbuffer=off"});
  scene::Scene s = litFloor(20000, 7);
  gpu.setScene(s);
  other.setScene(s);
  gpu.renderer->setGBufferPath(render::GBufferPath::Compute);
  other.renderer->setGBufferPath(render::GBufferPath::Compute);
  for (uint32_t width : {160u, 96u, 160u}) {
    render::FrameSettings f = frameSettings(Technique::Clustered, width, width * 7 / 10);
    auto [a, countsA] = renderWithCounts(gpu, f);
    auto [b, countsB] = renderWithCounts(other, f);
    bool computed = false;
    for (const render::PassTiming& p : a.passes) computed = computed || p.name == "resolve";
    CHECK(computed);  // the scene qualifies: opaque, untextured
    CHECK(a.culling.listEntries > 1000);
    CHECK(a.culling.listEntries == b.culling.listEntries);
    CHECK(a.culling.activeClusters == b.culling.activeClusters);
    CHECK(countsA.data == countsB.data);  // every pixel's exact light count
    CHECK(maxDifference(a.rgba, b.rgba) <= 1);
  }
  gpu.renderer->setGBufferPath(render::GBufferPath::Raster);
  CHECK(gpu.context->validationMessages.load() == 0);
  CHECK(other.context->validationMessages.load() == 0);
}

TEST_CASE("clustered shading per pixel and per subgroup: the same light counts and image") {
  // The clustered shading pass walks its tile's narrowed lists per subgroup on GPUs with subgroup
  // ballot and per pixel on CPU devices (techniques/clustered.cpp); a second renderer made with
  // --tune shade set to the other walk must count the same lights at every pixel. Twice:
  // 20,000 small lights, and 3,000 that each cover the whole view, which overflow what a tile can
  // narrow into shared memory (its pixels then walk their clusters' whole lists).
  Gpu& gpu = sharedGpu();
  if (!gpu.context->info.computeSubgroupShuffle) return;
  Gpu other = suiteWith({gpu.context->info.isCpu ? "shade=subgroup" : "shade=pixel"});
  // And the subgroup pass's walk before issue 16's stop 16 (--tune shade-variant=0, a
  // benchmark switch): a light a step for every pixel of a short segment, by ballot beyond.
  Gpu walk = suiteWith({"shade=subgroup", "shade-variant=0"});
  scene::Scene small = litFloor(20000, 7);
  scene::Scene huge = litFloor(0, 1);
  for (int i = 0; i < 3000; ++i) {
    huge.lights.push_back({glm::vec3(0.01f * i - 15.0f, 2.0f, 0.0f), 100.0f, glm::vec3(0.0005f), 1.0f, 1.0f});
  }
  for (const scene::Scene* s : {&small, &huge}) {
    gpu.setScene(*s);
    other.setScene(*s);
    walk.setScene(*s);
    render::FrameSettings f = frameSettings(Technique::Clustered, 160, 112);
    auto [a, countsA] = renderWithCounts(gpu, f);
    auto [b, countsB] = renderWithCounts(other, f);
    auto [c, countsC] = renderWithCounts(walk, f);
    CHECK_FALSE(a.culling.overflowed());
    CHECK(countsA.data == countsB.data);  // every pixel's exact light count
    CHECK(countsA.data == countsC.data);
    CHECK(maxDifference(a.rgba, b.rgba) <= 1);  // the same lights summed in another order
    CHECK(maxDifference(a.rgba, c.rgba) <= 1);
    float most = 0.0f;
    for (float count : countsA.data) most = std::max(most, count);
    MESSAGE(s->lights.size() << " lights: up to " << most << " reach a pixel");
    if (s == &huge) CHECK(most == 3000.0f);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
  CHECK(other.context->validationMessages.load() == 0);
  CHECK(walk.context->validationMessages.load() == 0);
}

TEST_CASE("clustered shading from the whole lists: the same light counts and image as narrowed") {
  // CPU devices shade from the clusters' whole lists while the lists are short
  // (light_clustered_whole.comp, techniques/clustered.cpp kWholeListsUpTo): every pixel must count
  // the same lights as after the tile's narrowing, with short lists and with 3,000 lights that
  // each cover the whole view.
  Gpu narrowed = suiteWith({"shade=pixel"});
  Gpu whole = suiteWith({"shade=whole"});
  scene::Scene small = litFloor(2000, 7);
  scene::Scene huge = litFloor(0, 1);
  for (int i = 0; i < 3000; ++i) {
    huge.lights.push_back({glm::vec3(0.01f * i - 15.0f, 2.0f, 0.0f), 100.0f, glm::vec3(0.0005f), 1.0f, 1.0f});
  }
  for (const scene::Scene* s : {&small, &huge}) {
    narrowed.setScene(*s);
    whole.setScene(*s);
    render::FrameSettings f = frameSettings(Technique::Clustered, 160, 112);
    auto [a, countsA] = renderWithCounts(narrowed, f);
    auto [b, countsB] = renderWithCounts(whole, f);
    CHECK_FALSE(a.culling.overflowed());
    CHECK(a.culling.listEntries == b.culling.listEntries);
    CHECK(countsA.data == countsB.data);  // every pixel's exact light count
    CHECK(maxDifference(a.rgba, b.rgba) <= 1);  // the same lights summed in another order
  }
  CHECK(narrowed.context->validationMessages.load() == 0);
  CHECK(whole.context->validationMessages.load() == 0);
}

TEST_CASE("overflowing lists are counted and reported, never silent; tiled's never overflow") {
  // 3,000 lights of radius 100 all cover every cluster and tile with geometry.
  scene::Scene s = litFloor(0, 1);
  for (int i = 0; i < 3000; ++i) {
    s.lights.push_back({glm::vec3(0.01f * i, 2.0f, 0.0f), 100.0f, glm::vec3(0.0005f), 1.0f, 1.0f});
  }
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  // Lists this small cannot grow (growth is tested on its own): the overflow stays and is reported.
  constexpr uint64_t kListBytes = (1u << 18) * sizeof(uint32_t);
  gpu.renderer->limitListMemory(kListBytes);

  // Tiled's tiles hold all 3,000 (more than a list of MYRIAD_TILE_MAX_LIGHTS): shaded a list at
  // a time, nothing dropped.
  render::Frame tiled = gpu.render(frameSettings(Technique::Tiled, 256, 160));
  CHECK_FALSE(tiled.culling.overflowed());
  CHECK(tiled.culling.tileLightsDropped == 0);
  CHECK(tiled.culling.mostLightsInList == 3000);

  // Clustered lists limited to 2^18 references: 3,000 lights x every active cluster is more once
  // enough clusters are active.
  render::Frame clustered = gpu.render(frameSettings(Technique::Clustered, 1024, 640));
  uint64_t wanted = uint64_t(clustered.culling.activeClusters) * 3000;
  MESSAGE("clustered: " << clustered.culling.activeClusters << " active clusters, "
                        << clustered.culling.listEntries << " references kept, "
                        << clustered.culling.clusterLightsDropped << " dropped");
  REQUIRE(wanted > clustered.culling.listEntries);
  CHECK(clustered.culling.clusterLightsDropped == wanted - clustered.culling.listEntries);
  CHECK(clustered.culling.overflowed());
  CHECK(clustered.culling.listCapacity == kListBytes / sizeof(uint32_t));
  CHECK_FALSE(clustered.culling.listsGrew);
  gpu.renderer->limitListMemory(0);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a million animated lights render with the clustered technique, without overflow") {
  Gpu& gpu = sharedGpu();
  scene::Scene s = scene::makeBuiltinScene(1000000, 3);
  REQUIRE(s.lights.size() == 1000000);
  gpu.setScene(s);
  render::FrameSettings f;
  f.width = 160;
  f.height = 90;
  f.camera = s.camera;
  f.animate = true;
  std::vector<uint8_t> previous;
  for (double time : {0.0, 0.5}) {
    f.time = time;
    render::Frame frame = gpu.render(f);
    MESSAGE("1M lights, t=" << time << ": " << frame.culling.listEntries << " references, "
                            << frame.culling.activeClusters << " active clusters, longest list "
                            << frame.culling.mostLightsInList << ", lists "
                            << frame.culling.listBytes / (1 << 20) << " MiB");
    for (const auto& pass : frame.passes) MESSAGE("  " << pass.name << ": " << pass.milliseconds << " ms");
    CHECK(frame.lightCount == 1000000);
    CHECK_FALSE(frame.culling.overflowed());
    CHECK_FALSE(frame.culling.listsGrew);  // the lists' first sizing holds them; no second render
    CHECK(frame.culling.listEntries > 0);
    if (!previous.empty()) CHECK(maxDifference(previous, frame.rgba) > 10);  // the lights moved
    previous = frame.rgba;
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

namespace {

// A spot light (inverse-square, the glTF default) aimed down and forward at the floor, a window
// spot and an inverse-square point light; sun, ambient and background off unless asked.
scene::PointLight spotLight(glm::vec3 position, glm::vec3 direction, float inner, float outer,
                            float radius, float intensity, scene::Attenuation attenuation) {
  scene::PointLight l;
  l.position = position;
  l.radius = radius;
  l.color = glm::vec3(1.0f, 0.9f, 0.7f);
  l.intensity = intensity;
  l.falloff = 1.0f;
  l.type = scene::LightType::Spot;
  l.attenuation = attenuation;
  l.direction = glm::normalize(direction);
  l.innerConeAngle = inner;
  l.outerConeAngle = outer;
  return l;
}

scene::Scene spotScene(bool withOthers) {
  scene::Scene s = litFloor(0, 1);
  s.sun.intensity = 0.0f;
  s.ambient = glm::vec3(0.0f);
  s.background = glm::vec3(0.0f);
  s.lights.push_back(spotLight(glm::vec3(-0.5f, 3.0f, -1.0f), glm::vec3(0.2f, -1.0f, -0.1f), 0.2f,
                               0.45f, 9.0f, 12.0f, scene::Attenuation::InverseSquare));
  if (withOthers) {
    s.sun.intensity = 0.3f;
    s.ambient = glm::vec3(0.02f);
    // Two more directional lights (a model's glTF directional lights join the sun like this).
    s.extraSuns = {scene::Sun{glm::normalize(glm::vec3(0.6f, -1.0f, 0.2f)), glm::vec3(0.4f, 0.5f, 1.0f), 0.4f},
                   scene::Sun{glm::normalize(glm::vec3(-0.8f, -0.5f, -0.3f)), glm::vec3(1.0f, 0.6f, 0.3f), 0.25f}};
    s.lights.push_back(spotLight(glm::vec3(2.5f, 1.5f, 0.5f), glm::vec3(-0.5f, -1.0f, -0.6f), 0.0f,
                                 0.7f, 4.0f, 3.0f, scene::Attenuation::Window));
    scene::PointLight point;
    point.position = glm::vec3(-3.5f, 0.8f, 0.5f);
    point.radius = 5.0f;
    point.color = glm::vec3(0.4f, 0.6f, 1.0f);
    point.intensity = 2.0f;
    point.attenuation = scene::Attenuation::InverseSquare;
    s.lights.push_back(point);
    // A headlight: an inverse-square spot at the eye, pointing where the camera looks (every
    // pixel is on one of its rays; the distance bound keeps it finite).
    s.lights.push_back(spotLight(glm::vec3(0.0f, 4.0f, 8.0f), glm::vec3(0.0f, -4.0f, -10.0f), 0.05f,
                                 0.15f, 30.0f, 20.0f, scene::Attenuation::InverseSquare));
    // A spot whose cone spans pi/2 (a half space), seen from above.
    s.lights.push_back(spotLight(glm::vec3(0.5f, 0.4f, -3.5f), glm::vec3(1.0f, 0.0f, 0.2f), 1.2f,
                                 1.5707963f, 3.0f, 1.5f, scene::Attenuation::InverseSquare));
  }
  return s;
}

}  // namespace

TEST_CASE("spot, inverse-square and extra directional lights: every technique the same within 1/255, matching the reference") {
  scene::Scene s = spotScene(true);
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  std::vector<uint8_t> reference =
      render::renderReference(s, frameSettings(Technique::Clustered, 192, 128).takeLightingFrom(s));
  std::vector<std::vector<uint8_t>> images;
  for (Technique t : kTechniques) {
    render::Frame frame = gpu.render(frameSettings(t, 192, 128));
    CAPTURE(render::techniqueName(t));
    CHECK_FALSE(frame.culling.overflowed());
    int vsReference = maxDifference(frame.rgba, reference);
    MESSAGE("spot scene, " << render::techniqueName(t) << ": max difference from the reference "
                           << vsReference << "/255");
    CHECK(vsReference <= 2);
    images.push_back(std::move(frame.rgba));
    render::FrameSettings raw = frameSettings(t, 192, 128);
    raw.raw = true;
    const render::Frame values = gpu.render(raw);
    size_t nonFinite = 0;
    for (float v : values.data) nonFinite += std::isfinite(v) ? 0 : 1;
    CHECK(nonFinite == 0);
  }
  for (size_t a = 0; a < images.size(); ++a) {
    for (size_t b = a + 1; b < images.size(); ++b) {
      CAPTURE(render::techniqueName(kTechniques[a]));
      CAPTURE(render::techniqueName(kTechniques[b]));
      CHECK(maxDifference(images[a], images[b]) <= 1);
    }
  }
  // The lights do show: the image differs from the one lit by the sun and ambient alone, and the
  // extra suns from the one without them.
  scene::Scene oneSun = s;
  oneSun.extraSuns.clear();
  CHECK(maxDifference(render::renderReference(oneSun, frameSettings(Technique::Clustered, 192, 128)
                                                          .takeLightingFrom(oneSun)),
                      reference) > 20);
  scene::Scene unlit = s;
  unlit.lights.clear();
  CHECK(maxDifference(render::renderReference(unlit, frameSettings(Technique::Clustered, 192, 128)
                                                         .takeLightingFrom(unlit)),
                      reference) > 40);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// The compute techniques shade with a shader specialised to the kinds of light the scene holds
// (render/shading_features.h: a frame without spot lights or without one of the falloffs has that
// code compiled out). Edits that bring a kind in or take the last one out must be followed.
TEST_CASE("light edits that add or remove spot cones and falloff kinds shade right in every technique") {
  const scene::Scene spots = spotScene(true);
  scene::Scene points = spots;  // the same lights as window-falloff point lights
  for (scene::PointLight& l : points.lights) {
    l.type = scene::LightType::Point;
    l.attenuation = scene::Attenuation::Window;
  }
  Gpu& gpu = sharedGpu();
  gpu.setScene(points);
  const auto n = static_cast<uint32_t>(spots.lights.size());
  auto update = [&](const scene::Scene& from, uint32_t count) {
    render::LightUpdate u{count, {}};
    for (uint32_t i = 0; i < count; ++i) u.writes.push_back({i, from.lights[i]});
    gpu.renderer->updateLights(gpu.scene, u);
  };
  auto check = [&](const scene::Scene& expected, const char* what) {
    const std::vector<uint8_t> reference = render::renderReference(
        expected, frameSettings(Technique::Clustered, 192, 128).takeLightingFrom(expected));
    for (Technique t : kTechniques) {
      CAPTURE(what);
      CAPTURE(render::techniqueName(t));
      const int d = maxDifference(gpu.render(frameSettings(t, 192, 128)).rgba, reference);
      MESSAGE(what << ", " << render::techniqueName(t) << ": " << d << "/255 from the reference");
      CHECK(d <= 2);
    }
  };
  check(points, "window point lights");
  update(spots, n);  // every light becomes what spotScene has: spots and inverse-square in
  check(spots, "spots and inverse-square after the edit");
  scene::Scene fewer = spots;  // the first light (an inverse-square spot) alone, then window points
  fewer.lights.resize(1);
  update(fewer, 1);
  check(fewer, "one inverse-square spot left");
  for (scene::PointLight& l : fewer.lights) l = points.lights[0];
  update(fewer, 1);  // the last spot and inverse-square light edited back
  check(fewer, "one window point light left");
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("a spot light's cone edge is exact: nothing outside the outer cone, light and a count inside") {
  scene::Scene s = spotScene(false);
  const scene::PointLight spot = s.lights[0];
  const float cosOuter = std::cos(spot.outerConeAngle);
  Gpu& gpu = sharedGpu();
  gpu.setScene(s);
  render::FrameSettings f = frameSettings(Technique::Clustered, 192, 128);
  f.raw = true;
  f.target = render::Target::Position;
  const render::Frame positions = gpu.render(f);
  f.target = render::Target::Normal;
  const render::Frame normals = gpu.render(f);
  for (Technique t : kTechniques) {
    CAPTURE(render::techniqueName(t));
    f.technique = t;
    f.target = render::Target::Final;
    const render::Frame finals = gpu.render(f);
    f.target = render::Target::LightCount;
    const render::Frame counts = gpu.render(f);
    size_t outside = 0, nearOutside = 0, inside = 0, nearInside = 0, wrong = 0;
    for (size_t p = 0; p < size_t(f.width) * f.height; ++p) {
      const size_t i = p * 4;
      glm::vec3 position(positions.data[i], positions.data[i + 1], positions.data[i + 2]);
      glm::vec3 normal(normals.data[i], normals.data[i + 1], normals.data[i + 2]);
      if (position == glm::vec3(0.0f)) continue;  // sky
      glm::vec3 fromLight = position - spot.position;
      float d = glm::length(fromLight);
      float cd = glm::dot(spot.direction, fromLight / d);
      bool lit = finals.data[i] != 0.0f || finals.data[i + 1] != 0.0f || finals.data[i + 2] != 0.0f;
      float count = counts.data[i];
      if (d < spot.radius * 0.999f && cd < cosOuter - 1e-5f) {
        // Outside the outer cone (a hair of float rounding left either way): exactly nothing.
        ++outside;
        if (cd > cosOuter - 0.01f) ++nearOutside;
        if (lit || count != 0.0f) ++wrong;
      } else if (d < spot.radius * 0.999f && cd > cosOuter + 2e-3f &&
                 glm::dot(normal, -fromLight / d) > 0.05f) {
        // Inside (where half floats still hold the squared ramp) and facing the light.
        ++inside;
        if (cd < cosOuter + 0.01f) ++nearInside;
        if (!lit || count != 1.0f) ++wrong;
      }
    }
    MESSAGE(render::techniqueName(t) << ": " << outside << " pixels outside the cone (" << nearOutside
                                     << " within 0.01 in cosine), " << inside << " inside ("
                                     << nearInside << " within 0.01), " << wrong << " wrong");
    CHECK(nearOutside >= 20);
    CHECK(nearInside >= 20);
    CHECK(wrong == 0);
    for (float v : finals.data) REQUIRE(std::isfinite(v));
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}
