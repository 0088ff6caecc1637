// Measuring one configuration (scene, size, light count, technique): warm-up frames, then timed
// frames whose per-pass GPU times (timestamp queries) are summarised as medians and 90th
// percentiles, the culling report, and the pixel-light pairs one frame shades.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gpu/context.h"
#include "render/frame.h"
#include "render/renderer.h"

namespace myriad::bench {

// A practical ceiling for the lighting inner loop on an NVIDIA H200: a CUDA microkernel
// evaluating the glTF BRDF with windowed attenuation for every (pixel, light) pair, no culling,
// at 3840x2160 (../shared/device/README.md). Lighting time >= pairs / this.
inline constexpr double kH200PairsPerSecondCeiling = 3.1e11;
// Plan::orbitCamera's turn a frame: a whole orbit in 1,000 frames (bench_render_path.py's path).
inline constexpr float kOrbitDegreesPerFrame = 0.36f;

struct Plan {
  uint32_t width = 1920;
  uint32_t height = 1080;
  uint32_t warmupFrames = 10;
  uint32_t timedFrames = 50;
  double maxSecondsPerConfig = 30.0;  // timed frames stop early past this (at least 3 are kept)
  bool markers = false;
  // Anti-aliasing of the final image (fxaa: the "antialias" pass); the renderer's default, as a
  // session's, is fxaa. taa and ssaa render sub-frames (render/sub_frames.h): a frame's passes are
  // theirs summed, plus the host's "resolve-taa" or "resolve-ssaa" (host time, in the total too).
  render::Antialias antialias = render::Antialias::Fxaa;
  double frameSeconds = 1.0 / 60.0;  // animation time between frames
  // The environment light of every frame (none: the constant ambient, the seed's).
  render::EnvironmentMode environment = render::EnvironmentMode::None;
  // Rebuild the environment's maps every frame (the sun's colour changes by 1e-4 from one frame
  // to the next), so the "environment" pass is timed; otherwise it runs in the first warm-up
  // frame only and the timed frames measure shading alone.
  bool environmentEveryFrame = false;
  // The sun's shadow map, texels across (render::kShadowMapSizes); 0: no shadows. Timed as the
  // "shadow" pass.
  uint32_t sunShadowMap = 0;
  // The sun's cascades (1..render::kMaxSunCascades; the server's default 4) when sunShadowMap > 0.
  uint32_t sunCascades = render::kDefaultSunCascades;
  // The camera turns about the scene's target by kOrbitDegreesPerFrame a frame (a path, as a
  // fly-through or render_path moves it), and the sun stays: the cascades follow the camera
  // (scrolled or drawn again), which is what the "shadow" pass then times. Off: a still camera
  // and a sun that turns every other frame.
  bool orbitCamera = false;
  // With antialias taa: every frame resolved against one history, as a stream's (FrameSettings::
  // historyKey) instead of 8 sub-frames (--antialias taa-stream).
  bool streamHistory = false;
  // Lights asking for shadows added to every scene (bench_scene.h addShadowedLights), all given a
  // map (maxShadowedLights = this); their tiles are timed as the "light-shadows" pass. The tile
  // size is a quarter of sunShadowMap (2048 when the sun has none: 512-texel tiles).
  uint32_t shadowedLights = 0;
  bool shadowedSpots = false;  // spot lights (one tile each), else point lights (six)
  // How local lights cast shadows (--local-shadows). Stochastic: the BVH's build or refit is
  // timed as "bvh-build" / "bvh-refit" in frames that run it (every frame with --tune
  // bvh-update=rebuild or refit; else only the first warm-up frame builds it, the geometry being
  // still), the shading step as "shadow-rays"; each frame draws another sample (sampleIndex).
  render::LocalShadows localShadows = render::LocalShadows::Maps;
};

struct Summary {
  double median = 0.0;
  double p90 = 0.0;
};

struct PassSummary {
  std::string name;
  Summary ms;
};

struct ConfigResult {
  std::string scene;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t lights = 0;
  render::Technique technique = render::Technique::Clustered;
  std::string skipped;  // why the configuration was not run; empty when it ran

  uint32_t warmupFrames = 0;
  uint32_t timedFrames = 0;
  std::vector<PassSummary> passes;  // in frame order
  Summary totalMs;                  // sum of the passes of each frame
  Summary lightingMs;               // sun + lights (volumes) or lighting (compute, incl. assignment)
  Summary wallMs;                   // CPU wall time per frame: submit, wait, read back
  // What the timed frames did with the sun's maps (render::Frame::SunMap), with sun shadows.
  uint32_t sunMapsDrawn = 0, sunMapsScrolled = 0, sunMapsKept = 0;

  // Culling, over the timed frames: the worst frame for what must be zero, the last for the rest.
  uint32_t framesOverflowed = 0;
  uint32_t mostTilesOverflowed = 0;
  uint32_t mostTileLightsDropped = 0;
  uint32_t mostClusterLightsDropped = 0;
  uint32_t mostLightsInList = 0;
  uint32_t listEntries = 0;
  uint32_t activeClusters = 0;
  uint64_t lightBytes = 0;
  uint64_t listBytes = 0;

  // From one raw light-count frame at the first timed frame's time: lights that reach each pixel.
  uint64_t pairs = 0;
  uint32_t mostLightsAtPixel = 0;
  double pairsPerSecond = 0.0;   // pairs / median lighting time
  double ceilingFraction = 0.0;  // pairsPerSecond / kH200PairsPerSecondCeiling

  // Stochastic local shadows: the shadow rays one frame traces (a ray for each pixel with a
  // light sampled: at most, as a light facing away is not traced) and those per second of the
  // median "shadow-rays" pass, which also resamples the lights (so a lower bound of the trace's).
  uint64_t shadowRays = 0;
  double raysPerSecond = 0.0;

  uint32_t validationMessages = 0;  // new validation messages during this configuration
};

// Median and 90th percentile (nearest rank) of `values`; zeros when empty.
Summary summarize(std::vector<double> values);

// Runs one configuration on `scene`, which the renderer holds as `sceneId`, viewed from its camera
// and lit by its sun.
ConfigResult measure(render::Renderer& renderer, gpu::Context& context, render::SceneId sceneId,
                     const scene::Scene& scene, render::Technique technique, uint32_t lightCount,
                     const Plan& plan);

}  // namespace myriad::bench
