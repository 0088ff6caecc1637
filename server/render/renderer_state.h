// Renderer::State: what the renderer holds between frames (scenes, frame slots, pipelines, the
// techniques, the readback pool), shared by the files that implement the Renderer:
//   renderer.cpp         construction, scenes and edits, frame slots, beginFrame / finishFrame
//   frame_bindings.cpp   a frame's preparation: targets, uniforms, descriptor sets 0 and 1
//   frame_recording.cpp  the frame's commands up to the lighting, and the whole frame's order
//   after_lighting.cpp   the passes after the lighting, as a list of steps (registered passes too)
//   frame_readback.cpp   the readback pool, a frame read back, frame memory released and counted
//   split_frame.cpp      frames recorded as several bounded submissions (Renderer::SplitFrame)
// Internal to render/: nothing outside these files includes it.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "gpu/commands.h"
#include "gpu/resources.h"
#include "render/environment.h"
#include "render/extra_targets.h"
#include "render/frame_pass.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/motion.h"
#include "render/temporal.h"
#include "render/passes.h"
#include "render/renderer.h"
#include "render/scene_buffers.h"
#include "render/shadows.h"
#include "render/skinning.h"
#include "render/stochastic_shadows.h"
#include "render/techniques/technique.h"
#include "render/visibility.h"

namespace myriad::render {

// environment (when rebuilt), animate, shadow, light-shadows, gbuffer (or visibility + resolve),
// the technique's (sun + lights, lighting, or assign + shade), blend, markers, final, antialias,
// overlay, readback: room for a technique of three passes, or clustered's assignment timed step
// by step (--tune assign-steps=on, techniques/clustered.cpp: seven). Registered passes
// (render/frame_pass.h) add their own room.
constexpr uint32_t kMaxTimedPasses = 24;  // + bvh-build or bvh-refit

using Milliseconds = std::chrono::duration<double, std::milli>;

// The optional G-buffer targets (MYRIAD_GBUFFER_*) a frame reads: uv only for the uv view,
// emission for the emissive view and wherever a material emits, the layers (clear coat, sheen)
// wherever a material has one.
inline uint32_t gbufferWrites(const FrameSettings& s, const SceneBuffers& scene) {
  uint32_t written = 0;
  if (s.reads(Target::Uv)) written |= MYRIAD_GBUFFER_UV;
  if (s.reads(Target::Emissive) || scene.anyEmission()) written |= MYRIAD_GBUFFER_EMISSIVE;
  if (scene.anyLayers()) written |= MYRIAD_GBUFFER_LAYERS;
  return written;
}

inline double pixelsOf(const FrameSettings& settings) {
  return double(settings.width) * double(settings.height);
}

// What beginFrame and beginSplit refuse (std::invalid_argument): a size outside 1..maxDimension,
// a label target not read raw, motion among alsoRead.
void checkSize(const FrameSettings& settings, uint32_t maxDimension);
class SubFrameResolve;  // render/sub_frames.h
void checkLabels(const FrameSettings& settings);

// Everything submitted before (earlier frames on the queue included) happens before what follows.
void waitForEarlier(VkCommandBuffer cmd);

struct Renderer::State {
  State(gpu::Context& c, const Tuning& asked);

  gpu::Context& context;
  const Tuning tuning;  // resolved for the device (render/tuning.h)
  Pipelines pipelines;
  // A host-visible buffer a frame's pixels are read back into and lent out with the frame
  // (FrameSettings::borrowPixels): `held` from the frame's recording until its BorrowedPixels is
  // dropped (by whichever thread encoded it); only the render thread creates or frees them.
  struct PooledReadback {
    std::unique_ptr<gpu::Arena> arena;
    gpu::Buffer buffer;
    VkDeviceSize bytes = 0;
    std::atomic<bool> held{false};
  };
  std::vector<std::unique_ptr<PooledReadback>> readbacks;
  // A free pooled buffer of `bytes` (made if none is and fewer than kMaxPooledReadbacks exist),
  // marked held; null when every one is lent out. Frees the free ones of a size neither this
  // nor one a slot's targets were last made for (and, when the pool is full, one of those).
  PooledReadback* acquireReadback(VkDeviceSize bytes);
  // Frees the pooled buffers not lent out, but one of `keep` bytes when keep > 0.
  void trimReadbacks(VkDeviceSize keep = 0);
  // The pooled readback size a frame of `settings` asks for (0: none, it is not lent out).
  // A multi-target frame's extras follow the pixels in it (at extrasOffset), so they are lent out
  // with them.
  static VkDeviceSize readbackBytes(const FrameSettings& settings) {
    if (!settings.borrowPixels || settings.raw) return 0;
    return extrasOffset(settings) + VkDeviceSize(extraRegionsOf(settings).count) *
                                        settings.width * settings.height * 16;
  }
  static VkDeviceSize extrasOffset(const FrameSettings& settings) {
    const VkDeviceSize pixels = settings.yuv420Readback()
                                    ? yuv420Layout(settings.width, settings.height).bytes()
                                    : VkDeviceSize(settings.width) * settings.height * 4;
    return (pixels + 15) / 16 * 16;  // a copy of 16-byte texels starts on a multiple of 16
  }
  // The GPU's last timestamp of the previous whole frame finished (FrameTimes::gpuIdleMs).
  uint64_t lastGpuEndTick = 0;
  // Index = Technique (techniques/registry.h); destroyed before the pipeline layout they use.
  std::vector<std::unique_ptr<LightingTechnique>> techniques;
  ComputeGBuffer computeGBuffer;  // GBufferPath::Compute (render/visibility.h)
  SkinningPass skinning;          // skinned and morphed instances (render/skinning.h)
  MotionPass motion;              // Target::Motion (render/motion.h)
  StochasticShadows stochastic;   // settings.shadows.local stochastic (render/stochastic_shadows.h)
  // The streams' taa histories on the GPU, per FrameSettings::historyKey (render/temporal.h).
  std::unique_ptr<TemporalHistories> temporal;
  // Applies the frame's pose (and a motion frame's previous pose) to its scene where they differ
  // from what it holds, after the frames in flight finished with it.
  void applyPoses(SceneBuffers& scene, const FrameSettings& settings);
  GBufferPath gbufferPath = GBufferPath::Raster;
  gpu::Arena uniformArena;
  gpu::CommandRecorder recorder;  // scene uploads and edits (frames have their slot's)
  VkSampler sampler = VK_NULL_HANDLE;        // nearest: targets are read texel by texel
  VkSampler linearSampler = VK_NULL_HANDLE;  // the anti-aliasing pass's reads between pixels
  VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
  // What a frame renders into and reads through: one set per kind, rewritten for whichever scene
  // the frame draws. `slots` serve whole frames (beginFrame), one frame in flight each; `split`
  // the one split frame, so whole frames rendered between its submissions leave it untouched.
  // A slot in flight (submitted, not finished) is the GPU's: the host touches nothing of it
  // (uniforms, sets, targets, readback, counters, timestamps) until finishFrame waited for it.
  struct FrameSlot {
    gpu::Buffer uniforms;
    VkDescriptorSet sceneSet = VK_NULL_HANDLE;
    VkDescriptorSet targetSet = VK_NULL_HANDLE;  // set 2 (light culling) is each technique's own
    // targetSet with the output binding on targets->extraOutput: a multi-target frame's raw
    // views when its own output is 8-bit (render/extra_targets.h).
    VkDescriptorSet rawTargetSet = VK_NULL_HANDLE;
    // Sized for the frame being drawn, rebuilt when that changes.
    std::unique_ptr<FrameTargets> targets;
    // The compute G-buffer's buffers and set (when a frame of this slot took that path).
    std::unique_ptr<ComputeGBuffer::Slot> visibility;
    // The sun's shadow map, rendered by each frame that has it on: the slot's own, so whole
    // frames between a split frame's submissions do not overwrite the split frame's map.
    std::unique_ptr<ShadowMaps> shadows;
    // Which local lights have a shadow map this frame, and their tiles (prepareFrame plans it).
    LightShadowPlan lightShadows;
    Frame::SunMap sunMap = Frame::SunMap::none;  // what this frame did with the sun's map
    // What this frame's shading may need (writeUniforms: render/shading_features.h).
    uint32_t shadingFeatures = MYRIAD_FEATURES_ALL;
    gpu::CommandRecorder recorder;            // its command buffer and fence
    std::unique_ptr<gpu::PassTimer> timer;    // its timestamps
    gpu::Buffer counters;  // its copy of the technique's culling counters (CullingStats)
    // The pooled buffer this frame reads back into (borrowPixels), else null: targets->readback.
    PooledReadback* readback = nullptr;
    FrameTimes times;  // what the host measured of the frame in flight
    uint64_t lastUsed = 0;  // State::framesBegun when this slot last began a frame (0: never)
    // The frame in flight: what finishFrame needs besides the GPU's results (taken when it was
    // recorded, so a scene destroyed meanwhile does not matter).
    bool inFlight = false;
    SceneId scene = 0;
    FrameSettings settings;
    Frame meta;  // size, technique, light count, scene bytes; no pixels
    // The frame in flight is the last sub-frame of a taa or ssaa frame: the others, resolved
    // so far (render/sub_frames.h); finishFrame adds it and answers the resolved frame.
    std::shared_ptr<SubFrameResolve> resolve;
    // A stream's taa frame: its history's images and reprojection (render/temporal.h).
    TemporalFramePlan temporal;
  };
  std::vector<std::unique_ptr<FrameSlot>> slots;  // kMaxFramesInFlight; framesInFlight used
  uint64_t framesBegun = 0;  // whole frames begun so far (FrameSlot::lastUsed)
  // The free slot (index < framesInFlight) a whole frame of `settings` goes to: one whose targets
  // already have its size, else one that has none yet, else the one whose targets are nearest
  // its size (then the one used least recently). So a stream that alternates sizes (its small
  // interactive frames, whose scale changes, and its full-size still) keeps the still's targets
  // and sun map instead of making them again for every still. framesInFlight when every slot is
  // in flight.
  uint32_t pickSlot(const FrameSettings& settings) const;
  FrameSlot split;
  uint32_t framesInFlight = 1;
  bool overlap = false;  // setOverlap
  // What the last whole frame was recorded with: a frame that differs waits for those in flight
  // (its technique's prepare() may reallocate what they use).
  struct Shape {
    Technique technique = Technique::Clustered;
    uint32_t width = 0;
    uint32_t height = 0;
    bool raw = false;
    uint32_t lightCount = 0;
    bool operator==(const Shape&) const = default;
  };
  Shape lastShape;

  std::vector<FrameSlot*> allSlots() {
    std::vector<FrameSlot*> all;
    for (auto& slot : slots) all.push_back(slot.get());
    all.push_back(&split);
    return all;
  }
  // Waits for every frame in flight (they stay in flight until finishFrame reads them).
  void quiesce() {
    for (auto& slot : slots) {
      if (slot->inFlight) gpu::waitFor(context, slot->recorder);
    }
  }
  bool splitBusy = false;
  double sliceMs = kSliceMilliseconds;
  double wholeFrameMs = kWholeFrameMilliseconds;
  double frameBudgetMs = 0.0;  // setFrameBudgetMilliseconds; 0: none
  // What the last frame of each scene cost (a whole frame's GPU time, a split frame's parts'
  // host time), for estimateMilliseconds; forgotten when the scene is replaced or destroyed.
  struct FrameCost {
    Technique technique = Technique::Clustered;
    double pixels = 0.0;
    uint32_t lights = 0;
    double ms = 0.0;
  };
  std::unordered_map<SceneId, FrameCost> costs;
  // The split frame's instance of each technique (LightingTechnique::splitInstance; null: the
  // technique's own serves it too). Index = Technique.
  std::vector<std::unique_ptr<LightingTechnique>> splitTechniques;
  LightingTechnique& splitTechnique(Technique t) {
    LightingTechnique& own = technique(t);
    const auto index = static_cast<size_t>(t);
    return index < splitTechniques.size() && splitTechniques[index] ? *splitTechniques[index] : own;
  }
  std::unordered_map<SceneId, std::unique_ptr<SceneBuffers>> scenes;
  // The BRDF table and the passes that build environments (created after the recorder).
  std::unique_ptr<EnvironmentPasses> environmentPasses;
  // A scene's environment maps, from its first frame with the environment on or its first .hdr;
  // kept when the scene is replaced (a new model keeps the session's environment).
  std::unordered_map<SceneId, std::unique_ptr<SceneEnvironment>> environments;
  SceneId nextSceneId = 1;

  SceneBuffers& scene(SceneId id);
  const SceneBuffers& scene(SceneId id) const;
  LightingTechnique& technique(Technique t);
  void writeSceneSet(FrameSlot& slot, const SceneBuffers& scene, const gpu::Buffer& environment);
  SceneEnvironment& environment(SceneId id);
  // The sun's shadow map fitted to the scene and the sun, when the frame has sun shadows.
  static std::optional<SunShadowFit> sunShadowFor(const SceneBuffers& scene,
                                                  const FrameSettings& settings);
  SceneEnvironment* environmentFor(SceneId id, const FrameSettings& settings);
  void writeTargetSet(FrameSlot& slot);
  // rawTargetSet: targetSet's descriptors, the output binding on targets->extraOutput.
  void writeRawTargetSet(FrameSlot& slot);
  void writeUniforms(FrameSlot& slot, const FrameSettings& settings, const SceneBuffers& scene,
                     const LightingTechnique& technique, const SunShadowFit* sunShadow,
                     const LightShadowPlan& lightShadows);
  // True when it made them (none yet, or another size or kind: targetsFit).
  bool ensureTargets(FrameSlot& slot, VkExtent2D extent, bool raw);
  // Whether `targets` serve a frame of this size and kind as they are.
  bool targetsFit(const FrameTargets& targets, VkExtent2D extent, bool raw) const {
    return targets.extent.width == extent.width && targets.extent.height == extent.height &&
           targets.raw == raw && targets.computeWritable == computeWritableTargets();
  }
  // Records a whole frame into `slot` (not submitted) and fills slot.meta.
  // `waitAtStart`: the frame's first command waits for everything submitted before; otherwise
  // its lighting does (setOverlap).
  void recordFrame(FrameSlot& slot, SceneBuffers& scene, SceneEnvironment* environment,
                   const FrameSettings& settings, bool waitAtStart = true);
  // recordFrame, submit, wait, read back.
  Frame renderOnce(FrameSlot& slot, SceneBuffers& scene, SceneEnvironment* environment,
                   const FrameSettings& settings);
  static Frame metaOf(const SceneBuffers& scene, const SceneEnvironment* environment,
                      const FrameSettings& settings);
  // The steps of a frame, shared by whole and split frames. prepareFrame: true when it made the
  // slot's targets (Frame::madeTargets).
  bool prepareFrame(FrameSlot& slot, SceneBuffers& scene, SceneEnvironment* environment,
                    const FrameSettings& settings, LightingTechnique& technique);
  VkCommandBuffer beginFrameCommands(FrameSlot& slot, bool waitAtStart = true);
  // Whether targets are made storage-writable: the compute G-buffer may run on this device.
  bool computeWritableTargets() const {
    return gbufferPath != GBufferPath::Raster && computeGBuffer.supported();
  }
  // Whether this frame's G-buffer is made in compute (the path asks for it and the frame qualifies).
  bool computeGBufferFor(const SceneBuffers& scene, const FrameSettings& settings) const {
    if (!computeWritableTargets()) return false;
    // Labels test against the depth the raster pass writes with the same vertex stage.
    if (settings.drawsLabels()) return false;
    if (settings.target == Target::Motion) return false;  // the same: depth EQUAL
    if (gbufferPath == GBufferPath::Auto && context.info.type == "cpu") return false;
    return computeGBuffer.qualifies(scene, {settings.width, settings.height});
  }
  void recordBeforeLighting(VkCommandBuffer cmd, FrameSlot& slot, SceneBuffers& scene,
                            SceneEnvironment* environment, const FrameSettings& settings);
  // The passes after the lighting, in order, as steps a split frame records in parts (built
  // once, by the constructor): the forward ones (blend, markers), the registered passes on HDR
  // (render/frame_pass.h), the final pass (its workgroups in ranges), anti-aliasing with the
  // overlay and the counters' copy, the registered passes on the output, the readback.
  struct AfterStep {
    enum Kind { Forward, Final, Antialias, Registered, Readback } kind;
    const FramePass* pass = nullptr;       // Registered: what it is
    VkPipeline pipeline = VK_NULL_HANDLE;  // Registered: its pipeline (destroyed by ~Renderer)
  };
  std::vector<AfterStep> afterSteps;
  // Units of `step` for this frame (0: not recorded).
  uint32_t afterUnits(const AfterStep& step, const FrameSlot& slot, const SceneBuffers& scene,
                      const FrameSettings& settings) const;
  // Where the lighting leaves the images the after-lighting steps hand on (hdr and lightCount in
  // `lightingLayout`; the output not written yet, or the label or motion pass's).
  static FrameImageStates afterLightingStates(VkImageLayout lightingLayout,
                                              const FrameSettings& settings);
  void recordAfterStep(VkCommandBuffer cmd, const FrameSlot& slot, SceneBuffers& scene,
                       const FrameSettings& settings, LightingTechnique& technique,
                       FrameImageStates& images, const AfterStep& step, uint32_t first,
                       uint32_t count);
  // Every after-lighting step whole, then the timer's end.
  void recordAfterLighting(VkCommandBuffer cmd, const FrameSlot& slot, SceneBuffers& scene,
                           const FrameSettings& settings, LightingTechnique& technique,
                           VkImageLayout lightingLayout);
  // Records and submits the split frame's next part (ranges of its steps up to about a slice)
  // and waits for it; reads the lists' counters after the step that completes them.
  void runSplitPart(SplitFrame& frame);
  // Prepares the split frame's slot for frame.settings_, makes its steps and runs its first part
  // (beginSplit; again for each sub-frame of a taa or ssaa frame).
  void startSplit(SplitFrame& frame);
  // After the slot's last submission completed: its pixels, timings and counters, with `meta`.
  Frame readFrame(const FrameSlot& slot, const Frame& meta, const FrameSettings& settings,
                  LightingTechnique& technique);
};

}  // namespace myriad::render
