// What a frame request asks for and what a frame returns: the contract between the service and
// the renderer. Plain data; no Vulkan, no HTTP.
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
#include "scene/scene.h"

namespace myriad::render {

// A scene the renderer holds on the GPU (Renderer::createScene). Never 0; never reused.
using SceneId = uint32_t;

// Light edits (Renderer::updateLights). After the update the scene has `count` lights, and
// light[w.index] = w.light for each write; every index in [old count, count) must be written, and
// no index may be >= count. Only the written elements are uploaded, so an edit of one light costs
// one light, whatever the scene holds; the GPU buffers grow by doubling when `count` outgrows them.
// Removing light i of n: count = n - 1 and write the last light into i (if i < n - 1).
struct LightWrite {
  uint32_t index = 0;
  scene::PointLight light;
};

struct LightUpdate {
  uint32_t count = 0;
  std::vector<LightWrite> writes;
};

// New world transforms for some instances of a scene (Renderer::updateInstances): an object moved.
// The instances keep their meshes and materials; `bounds` is the whole scene's bounds after the
// move (scene::Scene::bounds() of the moved scene: the caller keeps them per instance).
struct InstanceWrite {
  uint32_t index = 0;  // into scene::Scene::instances
  glm::mat4 transform{1.0f};
};
struct InstanceUpdate {
  std::vector<InstanceWrite> writes;
  scene::Bounds bounds;
};

// A skinned or morphed instance posed at one time (scene/animation.h evaluates it): what the GPU
// pre-pass deforms its mesh's vertices by before the G-buffer, shadow and pick passes read them.
struct InstancePose {
  uint32_t instance = 0;  // index into scene::Scene::instances
  // Skinning matrices, one per joint of the instance's skin: the asset's space from the mesh's
  // bind space (world_asset(joint) * inverseBind). Empty: not skinned. The posed vertex is then
  // moved by the instance's transform as any other.
  std::vector<glm::mat4> joints;
  // One weight per morph target of its mesh (empty: the mesh's default weights).
  std::vector<float> morphWeights;
};

// A whole scene posed at `time`: node-animated instances' transforms and skinned or morphed
// instances' poses. A frame that carries one (FrameSettings::pose) is drawn in exactly that pose,
// so the same time gives the same bytes.
struct ScenePose {
  double time = 0.0;
  std::vector<InstanceWrite> transforms;
  std::vector<InstancePose> poses;
};

// The time between a motion frame and its previous time, in seconds (one frame at 30 Hz).
inline constexpr double kMotionInterval = 1.0 / 30.0;

// One material's new factors (Renderer::updateMaterials); index < the scene's material count.
struct MaterialWrite {
  uint32_t index = 0;
  scene::Material material;
};

// What the final pass (or, for data views, the views pass) writes into the output image. Values index protocol::kTargets (the names)
// and equal MYRIAD_VIEW_* in shaders/shared_types.h (render/gpu_types.h checks both).
enum class Target : uint32_t {
  Final = 0,
  Albedo,
  Normal,
  Position,
  Uv,
  Metallic,
  Roughness,
  Depth,
  LightVolumes,
  LightCount,  // heat map of the lights that shade each pixel, with its scale drawn in
  Clusters,    // the clustered technique's depth slices, one colour each
  Emissive,    // emitted radiance (emissive factor x strength x texture)
  Occlusion,   // the material's ambient occlusion (1 where it has none)
  // Labels: per pixel, the nearest opaque or alpha-tested surface's object id (0: none), its
  // object's semantic class, its material id. Drawn by their own pass (recordLabelPass) against
  // the G-buffer's depth and always read back raw: FrameSettings::raw must be set, and
  // Frame::data then holds four uint32 bit patterns a pixel (object, semantic, material, 1 where
  // a surface is; all 0 elsewhere), to be read with std::bit_cast, never as floats.
  InstanceId,
  SemanticId,
  MaterialId,
  // Screen-space motion in pixels from the previous time (FrameSettings::previousCamera,
  // previousPose) to the frame's: a surface's pixel now minus its pixel then (x right, y down),
  // for camera, instance, skin and morph motion alike (render/motion.h). Raw: dx, dy, 1 where a
  // surface is (else all 0), 0; 8-bit: a false-colour picture. Drawn against the raster G-buffer.
  Motion,
};

// Whether `target` is one of the label targets (InstanceId, SemanticId, MaterialId).
inline bool isLabel(Target target) {
  return target == Target::InstanceId || target == Target::SemanticId ||
         target == Target::MaterialId;
}

// FrameSettings::alsoRead holds at most this many targets (a frame reads at most 8 with its own).
inline constexpr size_t kMaxExtraTargets = 7;

// The names are the protocol's, defined once there.
inline constexpr const auto& kTargetNames = protocol::kTargets;
static_assert(kTargetNames.size() == static_cast<size_t>(Target::Motion) + 1);

inline std::string_view targetName(Target t) { return kTargetNames[static_cast<uint32_t>(t)]; }

inline std::optional<Target> parseTarget(std::string_view name) {
  for (uint32_t i = 0; i < kTargetNames.size(); ++i) {
    if (kTargetNames[i] == name) return static_cast<Target>(i);
  }
  return std::nullopt;
}

// How local lights are shaded. The same image whichever (tests hold them to 1/255 of each other);
// they differ in cost. A technique is an index into protocol::kTechniques, its name, and into
// render/techniques/registry.cpp, its implementation; there is no other list of them. The named
// values are the ones code refers to by name (defaults, tests); a new technique needs none.
enum class Technique : uint32_t {
  Volumes = 0,  // the seed's: one instanced draw of sphere proxies, additive blending
  Tiled,        // compute: 16x16-pixel tiles, lists in shared memory (Andersson 2011)
  Clustered,    // compute: tiles x depth slices, lists assigned on the GPU (Olsson et al. 2012)
};

inline constexpr const auto& kTechniqueNames = protocol::kTechniques;
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Volumes)] == protocol::techniques::kVolumes);
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Tiled)] == protocol::techniques::kTiled);
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Clustered)] ==
              protocol::techniques::kClustered);

// Every technique, in order.
inline std::vector<Technique> allTechniques() {
  std::vector<Technique> all;
  for (uint32_t i = 0; i < kTechniqueNames.size(); ++i) all.push_back(static_cast<Technique>(i));
  return all;
}

// "volumes, tiled or clustered": the names as a sentence lists them (usage, error messages).
inline std::string techniqueChoices() {
  std::string text;
  for (size_t i = 0; i < kTechniqueNames.size(); ++i) {
    if (i > 0) text += i + 1 == kTechniqueNames.size() ? " or " : ", ";
    text += kTechniqueNames[i];
  }
  return text;
}

inline std::string_view techniqueName(Technique t) {
  return kTechniqueNames[static_cast<uint32_t>(t)];
}

inline std::optional<Technique> parseTechnique(std::string_view name) {
  for (uint32_t i = 0; i < kTechniqueNames.size(); ++i) {
    if (kTechniqueNames[i] == name) return static_cast<Technique>(i);
  }
  return std::nullopt;
}

// How a frame's G-buffer is made (myriad-server and myriad-bench --gbuffer; render/visibility.h).
// Raster: the graphics pipeline (vertex + fragment shaders), every scene, every device. Compute:
// triangles rasterised by compute shaders into 64-bit depth+id keys, then materials resolved per
// pixel into the same targets; used for frames whose scene qualifies (opaque, untextured
// materials) on devices with 64-bit buffer atomics, the raster path otherwise. Auto: compute
// where it qualifies on a GPU, raster on CPU implementations (lavapipe), where raster is cheaper.
// A frame's pass names say which ran: "gbuffer", or "visibility" and "resolve". myriad-server's
// default is Auto, myriad-bench's Raster (its tables compare against earlier runs).
enum class GBufferPath : uint32_t { Raster = 0, Compute, Auto };
inline constexpr std::array<std::string_view, 3> kGBufferPathNames = {"raster", "compute", "auto"};

inline std::string_view gbufferPathName(GBufferPath p) {
  return kGBufferPathNames[static_cast<uint32_t>(p)];
}

inline std::optional<GBufferPath> parseGBufferPath(std::string_view name) {
  for (uint32_t i = 0; i < kGBufferPathNames.size(); ++i) {
    if (kGBufferPathNames[i] == name) return static_cast<GBufferPath>(i);
  }
  return std::nullopt;
}

// The environment light (image-based lighting; render/environment.cpp, shaders/environment.glsl).
// Values index protocol::kEnvironmentModes and equal MYRIAD_ENV_* (render/gpu_types.h checks).
enum class EnvironmentMode : uint32_t {
  None = 0,  // the constant `ambient` term, exactly as before the environment existed
  Sky,       // the procedural sky, from the sun's direction and colour
  Hdr,       // the scene's equirectangular .hdr (Renderer::setEnvironmentImage)
};

inline std::string_view environmentModeName(EnvironmentMode m) {
  return protocol::kEnvironmentModes[static_cast<uint32_t>(m)];
}

inline std::optional<EnvironmentMode> parseEnvironmentMode(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kEnvironmentModes.size(); ++i) {
    if (protocol::kEnvironmentModes[i] == name) return static_cast<EnvironmentMode>(i);
  }
  return std::nullopt;
}

// Anti-aliasing of the `final` view (8-bit output only: raw values and data views are never
// filtered). Values index protocol::kAntialiasModes and equal MYRIAD_ANTIALIAS_* (gpu_types.h).
enum class Antialias : uint32_t {
  None = 0,  // the tonemapped image as it is
  Fxaa,      // luminance-edge detection and a directional blend after tonemapping (antialias.comp)
};

inline std::string_view antialiasName(Antialias a) {
  return protocol::kAntialiasModes[static_cast<uint32_t>(a)];
}

inline std::optional<Antialias> parseAntialias(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kAntialiasModes.size(); ++i) {
    if (protocol::kAntialiasModes[i] == name) return static_cast<Antialias>(i);
  }
  return std::nullopt;
}

struct EnvironmentSettings {
  EnvironmentMode mode = EnvironmentMode::None;
  float intensity = 1.0f;   // scales the environment's light (and its background), >= 0
  float rotation = 0.0f;    // radians about +Y (hdr only: the sky's orientation is the sun's)
  bool background = false;  // show the environment where no geometry is (else `background`)
};

// How local lights cast shadows; the index into protocol::kLocalShadowModes.
enum class LocalShadows : uint32_t { None = 0, Maps, Stochastic };
static_assert(protocol::kLocalShadowModes.size() == 3);

inline std::string_view localShadowsName(LocalShadows m) {
  return protocol::kLocalShadowModes.at(static_cast<uint32_t>(m));
}

inline std::optional<LocalShadows> parseLocalShadows(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kLocalShadowModes.size(); ++i) {
    if (protocol::kLocalShadowModes[i] == name) return static_cast<LocalShadows>(i);
  }
  return std::nullopt;
}

// Shadows (render/shadows.h). Off by default at this level, so frames and tests that do not ask
// for them stay as they were; sessions turn the sun's on for their scenes (service/session_scene).
struct ShadowSettings {
  bool sun = false;         // the sun casts shadows (one map over the scene's bounds)
  uint32_t mapSize = 2048;  // the sun's map, texels across: kShadowMapSizes
  // Local lights asking for shadows (scene::PointLight::castsShadows) that get a map this frame,
  // at most: 0..MYRIAD_MAX_SHADOWED_LIGHTS (kMaxShadowedLights); the rest are unshadowed.
  uint32_t maxShadowedLights = 4;  // kDefaultShadowedLights
  // How local lights cast shadows (protocol::local_shadow_modes; render/stochastic_shadows.h):
  // None, Maps (the budgeted maps above, as before) or Stochastic (every light: a light sampled
  // per pixel from its cluster list, one shadow ray through the scene's BVH).
  LocalShadows local = LocalShadows::Maps;
};

// The most maxShadowedLights may be (shaders/shared_types.h MYRIAD_MAX_SHADOWED_LIGHTS; the
// schema's maximum, checked by the protocol test).
inline constexpr uint32_t kMaxShadowedLights = 16;
inline constexpr uint32_t kDefaultShadowedLights = 4;

// The sizes a shadow map may have (protocol/schemas/defs.schema.json's shadowMapSize).
inline constexpr std::array<uint32_t, 5> kShadowMapSizes = {256, 512, 1024, 2048, 4096};

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

  // Anti-aliasing filters the 8-bit `final` image only: never raw values or another view.
  bool antialiased() const {
    return antialias != Antialias::None && target == Target::Final && !raw;
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
  struct TargetValues {
    Target target = Target::Depth;
    std::vector<float> data;
  };
  std::vector<TargetValues> extras;
  // With a label in FrameSettings::alsoRead (and `target` not a label): the label pass's four
  // uint32 bit patterns a pixel, as `data` holds them for a label target.
  std::vector<float> labels;
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
  enum class SunMap : uint8_t { none, kept, repaired, drawn };
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
