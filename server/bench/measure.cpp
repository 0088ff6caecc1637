#include "bench/measure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

namespace myriad::bench {

namespace {

using Clock = std::chrono::steady_clock;

// Frames of the benchmark always animate: light assignment then runs every frame, as it must
// when lights move, rather than being skipped for a static scene.
render::FrameSettings frameSettings(const scene::Scene& scene, render::Technique technique,
                                    const Plan& plan, uint32_t frameIndex) {
  render::FrameSettings f;
  f.width = plan.width;
  f.height = plan.height;
  f.camera = scene.camera;
  f.takeLightingFrom(scene);
  f.technique = technique;
  f.markers = plan.markers;
  f.antialias = plan.antialias;
  if (plan.streamHistory) f.historyKey = 1;
  f.animate = true;
  f.time = frameIndex * plan.frameSeconds;
  f.environment.mode = plan.environment;
  if (plan.environmentEveryFrame) f.sun.color *= 1.0f + 1e-4f * float(frameIndex % 2);
  f.shadows.sun = plan.sunShadowMap > 0;
  if (plan.orbitCamera) {
    const float angle = glm::radians(kOrbitDegreesPerFrame * float(frameIndex));
    const glm::vec3 arm = f.camera.eye - f.camera.target;
    f.camera.eye = f.camera.target + glm::vec3(std::cos(angle) * arm.x + std::sin(angle) * arm.z, arm.y,
                                               std::cos(angle) * arm.z - std::sin(angle) * arm.x);
  }
  if (plan.sunShadowMap > 0 && plan.orbitCamera) {
    f.shadows.mapSize = plan.sunShadowMap;
    f.shadows.cascades = plan.sunCascades;
  } else if (plan.sunShadowMap > 0) {
    f.shadows.mapSize = plan.sunShadowMap;
    f.shadows.cascades = plan.sunCascades;
    // The renderer keeps a map whose scene and sun did not change (ShadowMaps::sunHolds); the sun
    // turns by 1e-4 rad every other frame so that each timed frame draws it, as --sun-shadows says.
    const float a = 1e-4f * float(frameIndex % 2);
    const glm::vec3 d = f.sun.direction;
    f.sun.direction = glm::vec3(std::cos(a) * d.x + std::sin(a) * d.z, d.y,
                                std::cos(a) * d.z - std::sin(a) * d.x);
  }
  f.shadows.maxShadowedLights = plan.shadowedLights;
  f.shadows.local = plan.localShadows;
  f.sampleIndex = frameIndex;
  return f;
}

// Lighting: volumes' "sun" + "lights", tiled's one "lighting" dispatch, clustered's "assign"
// (building the lists) + "shade".
double lightingMilliseconds(const render::Frame& frame) {
  double ms = 0.0;
  for (const auto& pass : frame.passes) {
    if (pass.name == "sun" || pass.name == "lights" || pass.name == "lighting" ||
        pass.name == "assign" || pass.name == "shade" || pass.name == "shadow-rays") {
      ms += pass.milliseconds;
    }
  }
  return ms;
}

}  // namespace

Summary summarize(std::vector<double> values) {
  Summary s;
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  size_t n = values.size();
  s.median = n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  size_t rank = static_cast<size_t>(std::ceil(0.9 * double(n)));
  s.p90 = values[std::clamp<size_t>(rank, 1, n) - 1];
  return s;
}

ConfigResult measure(render::Renderer& renderer, gpu::Context& context, render::SceneId sceneId,
                     const scene::Scene& scene, render::Technique technique, uint32_t lightCount,
                     const Plan& plan) {
  ConfigResult r;
  r.width = plan.width;
  r.height = plan.height;
  r.lights = lightCount;
  r.technique = technique;
  const uint32_t messagesBefore = context.validationMessages.load();

  uint32_t frameIndex = 0;
  for (uint32_t i = 0; i < plan.warmupFrames; ++i) {
    renderer.render(sceneId, frameSettings(scene, technique, plan, frameIndex++));
  }
  r.warmupFrames = plan.warmupFrames;

  const uint32_t firstTimed = frameIndex;
  std::vector<std::string> passOrder;
  std::map<std::string, std::vector<double>> passTimes;
  std::vector<double> totals, lighting, walls;
  const Clock::time_point started = Clock::now();
  constexpr uint32_t kFewestTimedFrames = 3;
  for (uint32_t i = 0; i < plan.timedFrames; ++i) {
    if (i >= kFewestTimedFrames &&
        std::chrono::duration<double>(Clock::now() - started).count() > plan.maxSecondsPerConfig) {
      break;
    }
    Clock::time_point before = Clock::now();
    render::Frame frame = renderer.render(sceneId, frameSettings(scene, technique, plan, frameIndex++));
    walls.push_back(std::chrono::duration<double, std::milli>(Clock::now() - before).count());
    double total = 0.0;
    for (const auto& pass : frame.passes) {
      if (!passTimes.contains(pass.name)) passOrder.push_back(pass.name);
      passTimes[pass.name].push_back(pass.milliseconds);
      total += pass.milliseconds;
    }
    totals.push_back(total);
    lighting.push_back(lightingMilliseconds(frame));
    r.sunMapsDrawn += frame.sunMap == render::Frame::SunMap::drawn ? 1 : 0;
    r.sunMapsScrolled += frame.sunMap == render::Frame::SunMap::scrolled ? 1 : 0;
    r.sunMapsKept += frame.sunMap == render::Frame::SunMap::kept ? 1 : 0;

    const render::CullingReport& c = frame.culling;
    if (c.overflowed()) ++r.framesOverflowed;
    r.mostTilesOverflowed = std::max(r.mostTilesOverflowed, c.tilesOverflowed);
    r.mostTileLightsDropped = std::max(r.mostTileLightsDropped, c.tileLightsDropped);
    r.mostClusterLightsDropped = std::max(r.mostClusterLightsDropped, c.clusterLightsDropped);
    r.mostLightsInList = std::max(r.mostLightsInList, c.mostLightsInList);
    r.listEntries = c.listEntries;
    r.activeClusters = c.activeClusters;
    r.lightBytes = c.lightBytes;
    r.listBytes = c.listBytes;
    ++r.timedFrames;
  }
  for (const std::string& name : passOrder) r.passes.push_back({name, summarize(passTimes[name])});
  r.totalMs = summarize(totals);
  r.lightingMs = summarize(lighting);
  r.wallMs = summarize(walls);

  // The pairs the lighting shaded: every light that reaches a pixel is one BRDF evaluation, the
  // same count for every technique (they shade the same image).
  render::FrameSettings countSettings = frameSettings(scene, technique, plan, firstTimed);
  countSettings.target = render::Target::LightCount;
  countSettings.raw = true;
  render::Frame counts = renderer.render(sceneId, countSettings);
  for (size_t i = 0; i < counts.data.size(); i += 4) {
    const auto lights = static_cast<uint32_t>(std::lround(counts.data[i]));
    r.pairs += lights;
    r.mostLightsAtPixel = std::max(r.mostLightsAtPixel, lights);
    r.shadowRays += lights > 0 ? 1 : 0;  // a light sampled: one shadow ray
  }
  if (!render::tracesLocalShadows(countSettings)) r.shadowRays = 0;
  for (const PassSummary& p : r.passes) {
    if (p.name == "shadow-rays" && p.ms.median > 0.0) {
      r.raysPerSecond = double(r.shadowRays) / (p.ms.median * 1e-3);
    }
  }
  if (r.lightingMs.median > 0.0) {
    r.pairsPerSecond = double(r.pairs) / (r.lightingMs.median * 1e-3);
    r.ceilingFraction = r.pairsPerSecond / kH200PairsPerSecondCeiling;
  }
  r.validationMessages = context.validationMessages.load() - messagesBefore;
  return r;
}

}  // namespace myriad::bench
