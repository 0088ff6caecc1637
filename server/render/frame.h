// What a frame request asks for and what a frame returns: the contract between the service and
// the renderer. Plain data; no Vulkan, no HTTP. The named choices a frame is made of (targets,
// techniques, ...) are in render/frame_options.h, the scene edits in render/scene_edit_types.h;
// both come with this header.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/constants.h"
#include "render/frame_options.h"
#include "render/scene_edit_types.h"
#include "scene/scene.h"

namespace myriad::render {

// Distance fog (aerial perspective; settings "fog", render/frame_passes/fog.cpp): on the lit
// picture, before tonemapping, a surface `d` metres from the camera keeps exp(-density * d) of its
// radiance and takes the rest from `color`; where no surface is the picture is left as it was.
struct FogSettings {
  float density = 0.0f;  // per metre, 0 to kMaxFogDensity; 0: off (no pass runs)
  glm::vec3 color{0.5f, 0.6f, 0.7f};  // linear radiance, a hazy sky's
};
inline constexpr float kMaxFogDensity = 10.0f;  // defs.schema.json fogDensity's maximum

// What a scene is shown with, kept between frames: a session's settings (GET/PATCH .../settings)
// are exactly this, and every frame starts from it. Scene-wide lighting comes with the frame, not
// the scene upload, so a settings change needs no upload. The lighting defaults are
// scene::Scene's; takeLightingFrom() copies a scene's own.
struct SceneSettings {
  scene::Sun sun;
  std::vector<scene::Sun> extraSuns;  // at most scene::kMaxExtraSuns (a model's directional lights)
  glm::vec3 ambient = scene::Scene{}.ambient;
  glm::vec3 background = scene::Scene{}.background;
  float exposure = 1.0f;
  bool markers = true;
  Antialias antialias = Antialias::Fxaa;  // applies to `final` only
  Technique technique = Technique::Clustered;
  bool animate = false;  // lights move (on the GPU) with the animation clock
  EnvironmentSettings environment;  // with mode None, `ambient` lights the scene; else not
  ShadowSettings shadows;
  FogSettings fog;

  // Sets sun, ambient and background to `scene`'s (what the scene was authored with).
  SceneSettings& takeLightingFrom(const scene::Scene& scene) {
    sun = scene.sun;
    extraSuns = scene.extraSuns;
    ambient = scene.ambient;
    background = scene.background;
    return *this;
  }
};

// One frame: the scene's settings (the base) plus what this frame alone asks for.
struct FrameSettings : SceneSettings {
  uint32_t width = 1280;
  uint32_t height = 720;
  scene::Camera camera;
  Target target = Target::Final;
  double time = 0.0;        // animation time in seconds (lights move only with `animate`)
  // The scene's pose at `time` (null: as last drawn; a scene without animation never has one).
  std::shared_ptr<const ScenePose> pose;
  // The motion target's previous time (Target::Motion; other targets ignore both): the camera
  // and the pose then (the service passes the pose at T - kMotionInterval, so ?time=T's motion
  // is exact and deterministic, and the camera of the session's previous frame). No previous
  // camera: the frame's own; no previous pose: every instance and deformed mesh as now.
  std::optional<scene::Camera> previousCamera;
  std::shared_ptr<const ScenePose> previousPose;
  // Stochastic local shadows (ShadowSettings::local): which sample of the pixel's estimate this
  // frame draws. The same index gives the same image; frames averaged over indices 0..N-1
  // converge to the exact shadows (tests/stochastic_shadow_tests.cpp).
  uint32_t sampleIndex = 0;
  // Sub-pixel offset of the projection, in pixels (x right, y down), each within +-0.5: TAA's
  // sub-frames (render/sub_frames.h) set it; every other frame leaves it 0 (unjittered).
  glm::vec2 jitter{0.0f, 0.0f};
  // A stream's key (0: none, every still): with antialias taa on the 8-bit `final` alone (no
  // alsoRead), the frame is one jittered frame resolved against this key's history on the GPU
  // (render/temporal.h) instead of 8 sub-frames. Other frames ignore it.
  uint64_t historyKey = 0;
  uint32_t heatMapMax = 0;  // light-count view: count shown as the hottest colour (0 = auto)
  bool raw = false;         // return the view's float values (Frame::data), not an image
  // The 8-bit pixels stay in the renderer's readback memory (Frame::borrowed) instead of being
  // copied into Frame::rgba on the render thread: for a caller that encodes the frame at once and
  // drops it (the service's JPEG and PNG frames). Ignored for raw frames.
  bool borrowPixels = false;
  // Read `final` back as JPEG's YCbCr 4:2:0 planes (yuv420Layout; Frame::yuv420) instead of
  // RGBA: 1.5 bytes a pixel, converted on the GPU (shaders/yuv420.comp). For JPEG frames with
  // subsampled chroma only; honoured for the 8-bit final picture (yuv420Readback()).
  bool yuv420 = false;
  // > 0: the G-buffer may draw a mesh's coarser version (scene::Mesh::lods) where its error
  // projects to at most this many pixels (a stream's interactive frames: fewer triangles for
  // llvmpipe's vertex work). 0: always the full meshes (every still, every GET frame).
  float geometryErrorPixels = 0.0f;
  // A multi-target frame (GET .../frame?target=a,b,c): views read back raw from this same render
  // after `target`'s own readback, each into Frame::extras (render/extra_targets.h). Not `target`
  // itself, not `final` or `light-volumes` (pictures of the lighting: only as `target`), each
  // once; label targets share one readback (Frame::labels, unless `target` is a label: then
  // Frame::data holds them). At most kMaxExtraTargets.
  std::vector<Target> alsoRead;

  bool yuv420Readback() const { return yuv420 && target == Target::Final && !raw; }

  FrameSettings& takeLightingFrom(const scene::Scene& scene) {
    SceneSettings::takeLightingFrom(scene);
    return *this;
  }

  // The frame draws the label pass: `target` or one of alsoRead is a label.
  bool drawsLabels() const {
    if (isLabel(target)) return true;
    for (Target t : alsoRead) {
      if (isLabel(t)) return true;
    }
    return false;
  }
  // The frame reads `t`'s G-buffer values: it is `target` or one of alsoRead.
  bool reads(Target t) const {
    if (t == target) return true;
    for (Target a : alsoRead) {
      if (a == t) return true;
    }
    return false;
  }

  // Anti-aliasing filters the 8-bit `final` image only: never raw values or another view. This
  // one: the FXAA pass runs on this frame's output (FrameUniforms.post.x).
  bool antialiased() const {
    return antialias == Antialias::Fxaa && target == Target::Final && !raw;
  }
  // The frame is made of sub-frames (Taa, Ssaa on the 8-bit `final`): the renderer renders them
  // with Antialias::None and resolves their pixels (render/sub_frames.h).
  // A temporalHistory() frame is not.
  bool resolvedFromSubFrames() const {
    return (antialias == Antialias::Taa || antialias == Antialias::Ssaa) &&
           target == Target::Final && !raw && !temporalHistory();
  }
  // A stream's taa frame: one jittered frame resolved against its history (render/temporal.h).
  // Not a multi-target frame: its data views come from an unjittered render (sub-frames).
  bool temporalHistory() const {
    return antialias == Antialias::Taa && historyKey != 0 && target == Target::Final && !raw &&
           alsoRead.empty();
  }
};

// Whether a frame traces every local light's shadow (render/stochastic_shadows.h): stochastic
// with the clustered technique, whose cluster lists the lights are drawn from; the other
// techniques shade stochastic as maps.
inline bool tracesLocalShadows(const FrameSettings& s) {
  return s.shadows.local == LocalShadows::Stochastic && s.technique == Technique::Clustered;
}

// What light culling did this frame. Nothing is dropped silently: a list that overflowed its
// capacity is counted here (and reported in stats, Server-Timing and the log).
struct CullingReport {
  uint32_t tilesOverflowed = 0;       // tiled: tiles with more lights than a tile list holds
  uint32_t tileLightsDropped = 0;     // tiled: light references those tiles could not hold
  uint32_t clusterLightsDropped = 0;  // clustered: light references past the list capacity
  uint32_t listEntries = 0;           // clustered: light references written
  uint32_t activeClusters = 0;        // clustered: clusters holding visible geometry
  uint32_t mostLightsInList = 0;      // tiled or clustered: the longest list
  uint64_t lightBytes = 0;            // GPU memory holding the lights (current + origins)
  uint64_t listBytes = 0;             // GPU memory holding the cluster grid and lists
  uint32_t listCapacity = 0;          // clustered: light references the lists hold this frame
  bool listsGrew = false;  // clustered: the lists overflowed, grew, and the frame was re-rendered

  bool overflowed() const { return tileLightsDropped > 0 || clusterLightsDropped > 0; }
};

// Names of the meaningful channels of a raw frame of `target`, in order (the rest are 0/1).
inline std::vector<std::string_view> rawChannels(Target target) {
  switch (target) {
    case Target::Final:
    case Target::LightVolumes: return {"r", "g", "b"};  // HDR radiance, before exposure
    case Target::Albedo: return {"r", "g", "b"};        // linear base colour
    case Target::Normal: return {"x", "y", "z"};        // world-space unit normal
    case Target::Position: return {"x", "y", "z"};      // world-space position
    case Target::Uv: return {"u", "v"};
    case Target::Metallic: return {"metallic"};
    case Target::Roughness: return {"roughness"};
    case Target::Depth: return {"depth"};  // names-once: a channel; view depth, far if none
    case Target::LightCount: return {"count"};
    case Target::Clusters: return {"slice", "tile_x", "tile_y"};
    case Target::Emissive: return {"r", "g", "b"};  // emitted radiance, before exposure
    case Target::Occlusion: return {"occlusion"};  // names-once: a channel, named as its target
    // Labels: raw is one uint32 a pixel (the service picks the channel; rawLabelChannel).
    case Target::InstanceId: return {"object"};
    case Target::SemanticId: return {"semantic"};
    case Target::MaterialId: return {"material"};
    case Target::Motion: return {"dx", "dy"};  // pixels, from the previous time to this one
    case Target::Shadow: return {"lit", "cascade"};  // the sun's shadow factor, its cascade
  }
  return {};
}

struct PassTiming {
  std::string name;     // e.g. "gbuffer", "sun", "lights", "markers", "final", "antialias", "readback"
  double milliseconds;  // GPU time from timestamp queries
};

// Where the planes of a YCbCr 4:2:0 frame lie (FrameSettings::yuv420, shaders/yuv420.comp): Y
// rows of `yStride` bytes (the width rounded up to 8), `rows` of them (the height rounded up to
// 2); then Cb and then Cr, each `chromaStride` (yStride / 2) bytes by rows / 2. Padding repeats
// the last column and row.
struct Yuv420Layout {
  uint32_t yStride = 0;
  uint32_t rows = 0;
  uint32_t chromaStride = 0;
  size_t yBytes() const { return size_t(yStride) * rows; }
  size_t chromaBytes() const { return size_t(chromaStride) * (rows / 2); }
  size_t bytes() const { return yBytes() + 2 * chromaBytes(); }
};
inline Yuv420Layout yuv420Layout(uint32_t width, uint32_t height) {
  Yuv420Layout l;
  l.yStride = (width + 7u) & ~7u;
  l.rows = (height + 1u) & ~1u;
  l.chromaStride = l.yStride / 2;
  return l;
}

// A frame's pixels left in the renderer's host-visible readback memory (FrameSettings::
// borrowPixels): the memory is the frame's until the last reference is dropped, which hands it
// back to the renderer (from any thread). Hold it only while encoding.
struct BorrowedPixels {
  BorrowedPixels(const uint8_t* data, size_t size, std::function<void()> release)
      : bytes(data, size), release_(std::move(release)) {}
  ~BorrowedPixels() {
    if (release_) release_();
  }
  BorrowedPixels(const BorrowedPixels&) = delete;
  BorrowedPixels& operator=(const BorrowedPixels&) = delete;
  std::span<const uint8_t> bytes;

 private:
  std::function<void()> release_;
};

// How frames are timed on the GPU (Renderer::setGpuTimestamps; the server's --gpu-timestamps).
enum class GpuTimestamps { Passes, Frame, None };

// Where one frame's time went on the host and the GPU (render thread and renderer; the service
// adds its own stages in stats' `pipeline`). Milliseconds; -1 where not measured.
struct FrameTimes {
  double recordMs = 0.0;      // recording and submitting its command buffer (render thread)
  double gpuMs = -1.0;        // its first to last GPU timestamp
  double gpuIdleMs = -1.0;    // the GPU's idle time between the previous frame's end and its start
  double fenceWaitMs = 0.0;   // the render thread blocked on its fence
  double copyMs = 0.0;        // the render thread copying its pixels out (0 when borrowed)
  double submitToAnswerMs = 0.0;  // from its submission to its future being kept
};

// One rendered frame: tightly packed RGBA8 rows, top row first. The colour channels of `final` and
// `albedo` are sRGB-encoded; data views (normal, uv, depth...) hold their values directly.
struct Frame {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;
  // With FrameSettings::borrowPixels, the same bytes left in readback memory instead of `rgba`.
  std::shared_ptr<const BorrowedPixels> borrowed;
  // With FrameSettings::yuv420 (for `final`): the pixels are YCbCr 4:2:0 planes laid out as
  // yuv420Layout(width, height) says, not RGBA.
  bool yuv420 = false;
  // The 8-bit pixels, wherever they are.
  std::span<const uint8_t> pixels() const {
    return borrowed ? borrowed->bytes : std::span<const uint8_t>(rgba);
  }
  // With FrameSettings::raw: 4 floats per pixel, rows top first, instead of `rgba`. What the
  // channels hold per target is rawChannels(target).
  std::vector<float> data;
  // FrameSettings::alsoRead's views (not labels), in its order: 4 floats a pixel, as `data`.
  // With borrowPixels they stay in the frame's lent readback memory (valid while `borrowed` is
  // held: no copy on the render thread); otherwise they point into `extrasCopy`.
  struct TargetValues {
    Target target = Target::Depth;
    std::span<const float> data;
  };
  std::vector<TargetValues> extras;
  // With a label in FrameSettings::alsoRead (and `target` not a label): the label pass's four
  // uint32 bit patterns a pixel, as `data` holds them for a label target (lent or copied, as
  // `extras`).
  std::span<const float> labels;
  std::shared_ptr<const std::vector<float>> extrasCopy;
  // Gives the lent readback memory back now: pixels() is empty after, and so are the extras and
  // labels that were in it.
  void giveBackReadback() {
    if (borrowed && !extrasCopy) {
      extras.clear();
      labels = {};
    }
    borrowed.reset();
  }
  std::vector<PassTiming> passes;
  // How long the frame waited before its work began: from its submission to the render queue to
  // the start of its first GPU work, including the time behind other frames' submissions
  // (frames in flight, another frame's split parts), not only the render thread's queue.
  double queueMs = 0.0;
  FrameTimes times;
  // GPU submissions the frame took: 1, or more for a frame split into slices (Renderer::SplitFrame)
  uint32_t submissions = 1;
  // The whole frame made its slot's targets (its slot had none, or of another size or kind);
  // false when it drew into targets an earlier frame of its size left (Renderer::beginFrame).
  bool madeTargets = false;
  Technique technique = Technique::Clustered;
  uint32_t lightCount = 0;
  uint64_t sceneBytes = 0;  // GPU memory of the rendered scene (geometry, materials, lights)
  CullingReport culling;
  // Local lights' shadows this frame (render/shadows.h planLightShadows).
  struct LightShadows {
    std::vector<uint32_t> lights;  // indices of the lights that had a shadow map, most important first
    uint32_t requested = 0;        // lights asking for one whose light reaches into the view
    uint32_t dropped = 0;          // of those, past maxShadowedLights: shaded unshadowed
  } lightShadows;
  // What the frame did with the sun's shadow map: none (sun shadows off), kept (it held this
  // scene already), repaired (drawn again under a few moved objects only) or drawn whole.
  // kept: as it was; repaired: redrawn under moved objects; scrolled: shifted after a camera
  // move, the uncovered strips drawn (ShadowMaps::scrollSun); drawn: whole.
  enum class SunMap : uint8_t { none, kept, repaired, scrolled, drawn };
  SunMap sunMap = SunMap::none;
};

// A frame stopped because, its parts together, it took or would take the renderer longer than
// the per-frame budget (Renderer::setFrameBudgetMilliseconds). The service answers it as 413
// limit-exceeded naming the budget; a smaller frame, fewer lights or another technique fit.
class FrameBudgetError : public std::runtime_error {
 public:
  FrameBudgetError(const std::string& what, double budgetMs, double elapsedMs, double projectedMs)
      : std::runtime_error(what),
        budgetMs(budgetMs),
        elapsedMs(elapsedMs),
        projectedMs(projectedMs) {}
  double budgetMs;     // the budget
  double elapsedMs;    // what the frame's parts took before it stopped
  double projectedMs;  // what the whole frame was estimated to take then
};

}  // namespace myriad::render
