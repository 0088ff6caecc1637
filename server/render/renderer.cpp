#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/cluster_grid.h"
#include "render/compute_passes.h"
#include "render/environment.h"
#include "render/extra_targets.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/motion.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "render/shading_features.h"
#include "render/shadows.h"
#include "render/skinning.h"
#include "render/stochastic_shadows.h"
#include "render/visibility.h"
#include "render/techniques/registry.h"
#include "render/techniques/technique.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// environment (when rebuilt), animate, shadow, light-shadows, gbuffer (or visibility + resolve),
// the technique's (sun + lights, lighting, or assign + shade), blend, markers, final, antialias,
// overlay, readback: room for a technique of three passes, or clustered's assignment timed step
// by step (--tune assign-steps=on, techniques/clustered.cpp: seven).
constexpr uint32_t kMaxTimedPasses = 24;  // + bvh-build or bvh-refit

// The light-count view's hottest colour when the request leaves it to us.
constexpr uint32_t kDefaultHeatMapMax = 64;

// The frame uniforms are one small buffer; a default 64 MiB block would be almost all waste.
constexpr VkDeviceSize kUniformBlockSize = 64ull << 10;

// The optional G-buffer targets (MYRIAD_GBUFFER_*) a frame reads: uv only for the uv view,
// emission for the emissive view and wherever a material emits.
uint32_t gbufferWrites(const FrameSettings& s, const SceneBuffers& scene) {
  uint32_t written = 0;
  if (s.reads(Target::Uv)) written |= MYRIAD_GBUFFER_UV;
  if (s.reads(Target::Emissive) || scene.anyEmission()) written |= MYRIAD_GBUFFER_EMISSIVE;
  return written;
}

// Split frames (Renderer::SplitFrame). A frame of a scene not measured yet (no frame of it with
// that technique and about as many lights) splits when it has more lights than this, more pixels
// than this, or more pixels x lights: on lavapipe (2 cores) a 1920x1080 frame of the built-in
// scene's 256 lights takes about 0.5 s, 4096x4096 of 8 lights 3 s, 320x180 of a million
// clustered lights a minute. Splitting a frame that did not need it costs a few submissions.
constexpr uint32_t kUnmeasuredSplitLights = 65536;
constexpr double kUnmeasuredSplitPixels = 2560.0 * 1440.0;
constexpr double kUnmeasuredSplitPixelLights = 1920.0 * 1080.0 * 1024.0;
// A measured frame's cost is taken as valid for frames of its scene and technique with between
// half and twice its lights (cost ~ pixels x lights reaching them; fewer lights are not assumed
// cheaper, more are scaled up).
constexpr double kCostLightsRange = 2.0;
// The first range of a step with many units, before any of them was measured: this fraction of
// its units (at least one). Small: a light volume at 1920x1080 took 4.4 ms on lavapipe, and 1/1024
// of a million of them held the queue for 4.3 s; 15 of them 66 ms, and the next range is sized
// from that.
constexpr uint32_t kFirstRangeShare = 65536;
// A range weighs at most this many times the step's previous one, for units alike and not
// (LightingTechnique::Step::unitsAlike): a few units measured cheap do not let the next range
// take the rest of the step at once. Tiles differ most: a 16x16 tile of sky took 14 ms on
// lavapipe beside a million clustered lights, one of the floor below it 160-900 ms.
constexpr double kRangeGrowthAlike = 8.0;
constexpr double kRangeGrowthUnlike = 2.0;
// A step's ranges project the rest of it (for the frame budget) once one took this share of a
// slice: shorter ones are mostly the part's own overhead (a submission, a barrier, a wait).
constexpr double kWellMeasured = 0.25;
// How far a step's cost estimate falls after a cheaper range (runSplitPart), for units alike
// (the first ranges' part overhead fades in a few parts) and not (a costly tile keeps the
// estimate up for several parts).
constexpr double kEstimateDecayAlike = 0.5;
constexpr double kEstimateDecayUnlike = 0.9;
// A split frame projected past the frame budget stops once it has taken this share of it.
constexpr double kProjectAfterShare = 0.1;

// Readback buffers lent out with frames (FrameSettings::borrowPixels), at most: the frames in
// flight plus those being encoded (one per stream or waiting request). Past it a frame is copied
// out on the render thread as before.
constexpr size_t kMaxPooledReadbacks = 16;

using Milliseconds = std::chrono::duration<double, std::milli>;

// Adds `results` (one submission's passes) to `passes`, summing passes of the same name.
void addPasses(std::vector<PassTiming>& passes,
               const std::vector<std::pair<std::string, double>>& results) {
  // (No structured binding: clang before 16, which builds the fuzz preset, cannot capture one.)
  for (const auto& result : results) {
    const std::string& name = result.first;
    auto it = std::find_if(passes.begin(), passes.end(),
                           [&](const PassTiming& p) { return p.name == name; });
    if (it == passes.end()) {
      passes.push_back({name, result.second});
    } else {
      it->milliseconds += result.second;
    }
  }
}

}  // namespace

struct Renderer::State {
  State(gpu::Context& c, const Tuning& asked)
      : context(c), tuning(resolveTuning(asked, c.info)), pipelines(c),
        techniques(createTechniques({c, pipelines, tuning})),
        computeGBuffer(c, pipelines.sceneSetLayout, kMaxFramesInFlight + 1),
        skinning(c), motion(c, pipelines.sceneSetLayout, kMaxFramesInFlight + 1),
        stochastic(c, pipelines, tuning),
        uniformArena(c, kUniformBlockSize) {
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) slots.push_back(std::make_unique<FrameSlot>());
    for (FrameSlot* slot : allSlots()) {
      slot->shadows = std::make_unique<ShadowMaps>(c);
      slot->timer = std::make_unique<gpu::PassTimer>(c, kMaxTimedPasses);
    }
    for (const auto& technique : techniques) {
      splitTechniques.push_back(technique->splitInstance({c, pipelines, tuning}));
    }
  }

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
  static VkDeviceSize readbackBytes(const FrameSettings& settings) {
    if (!settings.borrowPixels || settings.raw) return 0;
    return settings.yuv420Readback() ? yuv420Layout(settings.width, settings.height).bytes()
                                     : VkDeviceSize(settings.width) * settings.height * 4;
  }
  // The GPU's last timestamp of the previous whole frame finished (FrameTimes::gpuIdleMs).
  uint64_t lastGpuEndTick = 0;
  // Index = Technique (techniques/registry.h); destroyed before the pipeline layout they use.
  std::vector<std::unique_ptr<LightingTechnique>> techniques;
  ComputeGBuffer computeGBuffer;  // GBufferPath::Compute (render/visibility.h)
  SkinningPass skinning;          // skinned and morphed instances (render/skinning.h)
  MotionPass motion;              // Target::Motion (render/motion.h)
  StochasticShadows stochastic;   // settings.shadows.local stochastic (render/stochastic_shadows.h)
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
  // The passes after the lighting, as steps a split frame records in parts: the forward ones
  // (blend, markers), the final pass (its workgroups in ranges), anti-aliasing with the overlay
  // and the counters' copy, the readback. Units of each step for this frame (0: not recorded).
  enum AfterStep : uint32_t { kForward, kFinal, kAntialias, kReadback, kAfterSteps };
  uint32_t afterUnits(AfterStep step, const FrameSlot& slot, const SceneBuffers& scene,
                      const FrameSettings& settings) const;
  // Layouts the after-lighting steps hand on.
  struct AfterLayouts {
    VkImageLayout lighting;  // where the lighting left hdr and lightCount
    VkImageLayout hdr;       // hdr after the blend pass
    VkImageLayout output = VK_IMAGE_LAYOUT_GENERAL;  // the output after the overlay pass
  };
  void recordAfterStep(VkCommandBuffer cmd, const FrameSlot& slot, SceneBuffers& scene,
                       const FrameSettings& settings, LightingTechnique& technique,
                       AfterLayouts& layouts, AfterStep step, uint32_t first, uint32_t count);
  // Every after-lighting step whole, then the timer's end.
  void recordAfterLighting(VkCommandBuffer cmd, const FrameSlot& slot, SceneBuffers& scene,
                           const FrameSettings& settings, LightingTechnique& technique,
                           VkImageLayout lightingLayout);
  // Records and submits the split frame's next part (ranges of its steps up to about a slice)
  // and waits for it; reads the lists' counters after the step that completes them.
  void runSplitPart(SplitFrame& frame);
  // After the slot's last submission completed: its pixels, timings and counters, with `meta`.
  Frame readFrame(const FrameSlot& slot, const Frame& meta, const FrameSettings& settings,
                  LightingTechnique& technique);
};

SceneBuffers& Renderer::State::scene(SceneId id) {
  auto it = scenes.find(id);
  if (it == scenes.end()) throw std::invalid_argument("no scene " + std::to_string(id) + " on the GPU");
  return *it->second;
}

const SceneBuffers& Renderer::State::scene(SceneId id) const {
  return const_cast<State*>(this)->scene(id);
}

LightingTechnique& Renderer::State::technique(Technique t) {
  const auto index = static_cast<size_t>(t);
  if (index >= techniques.size()) {
    throw std::invalid_argument("no lighting technique " + std::to_string(index));
  }
  return *techniques[index];
}

SceneEnvironment& Renderer::State::environment(SceneId id) {
  scene(id);  // throws for an unknown id
  std::unique_ptr<SceneEnvironment>& env = environments[id];
  if (!env) env = std::make_unique<SceneEnvironment>(context);
  return *env;
}

// `environment` is the scene's lighting maps, or any storage buffer when the environment is off
// (the shaders then never read it).
void Renderer::State::writeSceneSet(FrameSlot& slot, const SceneBuffers& scene,
                                    const gpu::Buffer& environment) {
  const VkDescriptorImageInfo sunShadowMap = slot.shadows->sunDescriptor();
  const VkDescriptorImageInfo lightShadowAtlas = slot.shadows->atlasDescriptor();
  VkDescriptorBufferInfo buffers[7] = {
      {slot.uniforms.buffer, 0, sizeof(FrameUniforms)},
      {scene.lights.buffer, 0, VK_WHOLE_SIZE},
      {scene.instances.buffer, 0, VK_WHOLE_SIZE},
      {scene.materials.buffer, 0, VK_WHOLE_SIZE},
      {scene.lightOrigins.buffer, 0, VK_WHOLE_SIZE},
      {environment.buffer, 0, VK_WHOLE_SIZE},
      {environmentPasses->brdfLut().buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[11];
  for (uint32_t i = 0; i < 7; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = slot.sceneSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        i == MYRIAD_BINDING_FRAME ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  writes[7] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  writes[7].dstSet = slot.sceneSet;
  writes[7].dstBinding = MYRIAD_BINDING_SUN_SHADOW_MAP;
  writes[7].descriptorCount = 1;
  writes[7].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[7].pImageInfo = &sunShadowMap;
  writes[8] = writes[7];
  writes[8].dstBinding = MYRIAD_BINDING_LIGHT_SHADOW_ATLAS;
  writes[8].pImageInfo = &lightShadowAtlas;
  writes[9] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  writes[9].dstSet = slot.sceneSet;
  writes[9].dstBinding = MYRIAD_BINDING_LIGHT_TEXELS;
  writes[9].descriptorCount = 1;
  writes[9].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
  writes[9].pTexelBufferView = &scene.lightTexels;
  writes[10] = writes[9];
  writes[10].dstBinding = MYRIAD_BINDING_MATERIAL_TEXELS;
  writes[10].pTexelBufferView = &scene.materialTexels;
  vkUpdateDescriptorSets(context.device, 11, writes, 0, nullptr);
}

void Renderer::State::writeTargetSet(FrameSlot& slot) {
  const std::unique_ptr<FrameTargets>& targets = slot.targets;
  // Bindings 0-6 and 9 are sampled (READ_ONLY_OPTIMAL); 7-8 are the same HDR and light-count
  // images as storage images (GENERAL), written by compute lighting; 10 the markers' keys, 11 the
  // output and 13 the LDR target are storage (GENERAL); 12 is the LDR target sampled with a
  // linear filter.
  constexpr uint32_t kBindings = 14;
  const gpu::Image* images[kBindings] = {
      &targets->depth,    &targets->normal,     &targets->baseColor, &targets->material,
      &targets->uv,       &targets->hdr,        &targets->lightCount, &targets->hdr,
      &targets->lightCount, &targets->emissive, &targets->markerKeys, &targets->output,
      &targets->ldr,      &targets->ldr};
  VkDescriptorImageInfo infos[kBindings];
  VkWriteDescriptorSet writes[kBindings];
  for (uint32_t i = 0; i < kBindings; ++i) {
    bool storage = i == MYRIAD_BINDING_HDR_STORAGE || i == MYRIAD_BINDING_LIGHT_COUNT_STORAGE ||
                   i == MYRIAD_BINDING_MARKER_KEYS || i == MYRIAD_BINDING_OUTPUT ||
                   i == MYRIAD_BINDING_LDR_STORAGE;
    VkSampler filter = i == MYRIAD_BINDING_LDR ? linearSampler : sampler;
    infos[i] = {storage ? VK_NULL_HANDLE : filter, images[i]->view,
                storage ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = slot.targetSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        storage ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &infos[i];
  }
  // 14: the edge pixels the final pass lists for anti-aliasing (a storage buffer).
  const VkDescriptorBufferInfo edges{targets->edges.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet edgeWrite{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  edgeWrite.dstSet = slot.targetSet;
  edgeWrite.dstBinding = MYRIAD_BINDING_EDGE_PIXELS;
  edgeWrite.descriptorCount = 1;
  edgeWrite.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  edgeWrite.pBufferInfo = &edges;
  // 15: the YCbCr planes (yuv420.comp).
  const VkDescriptorBufferInfo planes{targets->planes.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet planeWrite = edgeWrite;
  planeWrite.dstBinding = MYRIAD_BINDING_YUV_PLANES;
  planeWrite.pBufferInfo = &planes;
  // 16: the clusters the compute G-buffer marked (clustered).
  const VkDescriptorBufferInfo marks{targets->clusterMarks.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet markWrite = edgeWrite;
  markWrite.dstBinding = MYRIAD_BINDING_CLUSTER_MARKS;
  markWrite.pBufferInfo = &marks;
  vkUpdateDescriptorSets(context.device, kBindings, writes, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &edgeWrite, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &planeWrite, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &markWrite, 0, nullptr);
}

void Renderer::State::writeRawTargetSet(FrameSlot& slot) {
  std::vector<VkCopyDescriptorSet> copies;
  for (uint32_t binding = 0; binding <= MYRIAD_BINDING_CLUSTER_MARKS; ++binding) {
    if (binding == MYRIAD_BINDING_OUTPUT) continue;
    VkCopyDescriptorSet copy{VK_STRUCTURE_TYPE_COPY_DESCRIPTOR_SET};
    copy.srcSet = slot.targetSet;
    copy.srcBinding = binding;
    copy.dstSet = slot.rawTargetSet;
    copy.dstBinding = binding;
    copy.descriptorCount = 1;
    copies.push_back(copy);
  }
  const VkDescriptorImageInfo output{VK_NULL_HANDLE, slot.targets->extraOutput.view,
                                     VK_IMAGE_LAYOUT_GENERAL};
  VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = slot.rawTargetSet;
  write.dstBinding = MYRIAD_BINDING_OUTPUT;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  write.pImageInfo = &output;
  vkUpdateDescriptorSets(context.device, 1, &write, uint32_t(copies.size()), copies.data());
}

// Targets follow the output size and are rebuilt only when it changes (every frame is waited
// for, so nothing is in flight here).
bool Renderer::State::ensureTargets(FrameSlot& slot, VkExtent2D extent, bool raw) {
  std::unique_ptr<FrameTargets>& targets = slot.targets;
  if (!targets || !targetsFit(*targets, extent, raw)) {
    targets.reset();
    targets = std::make_unique<FrameTargets>(context, extent, raw, clusterGrid(extent, tuning),
                                             computeWritableTargets());
    writeTargetSet(slot);
    return true;
  }
  return false;
}

void Renderer::State::writeUniforms(FrameSlot& slot, const FrameSettings& s,
                                    const SceneBuffers& scene,
                                    const LightingTechnique& technique,
                                    const SunShadowFit* sunShadow,
                                    const LightShadowPlan& lightShadows) {
  float aspect = float(s.width) / float(s.height);
  glm::mat4 view = scene::viewMatrix(s.camera);
  glm::mat4 projection = scene::projectionMatrix(s.camera, aspect);
  const scene::Bounds& bounds = scene.bounds;

  FrameUniforms u{};
  u.view = view;
  u.projection = projection;
  u.viewProjection = projection * view;
  u.inverseViewProjection = glm::inverse(u.viewProjection);
  u.cameraPosition = glm::vec4(s.camera.eye, 1.0f);
  u.sunDirection = glm::vec4(-glm::normalize(s.sun.direction), s.sun.intensity);
  u.sunColor = glm::vec4(s.sun.color, 0.0f);
  for (size_t i = 0; i < s.extraSuns.size() && i < MYRIAD_MAX_EXTRA_SUNS; ++i) {
    u.extraSunDirection[i] = glm::vec4(-glm::normalize(s.extraSuns[i].direction), s.extraSuns[i].intensity);
    u.extraSunColor[i] = glm::vec4(s.extraSuns[i].color, 0.0f);
  }
  u.ambient = glm::vec4(s.ambient, 0.0f);
  u.background = glm::vec4(s.background, 0.0f);
  u.viewport = glm::vec4(s.width, s.height, 1.0f / s.width, 1.0f / s.height);
  // w is unused (markers are sized in pixels: shaders/markers.glsl).
  u.camera = glm::vec4(s.exposure, s.camera.nearPlane, s.camera.farPlane, 0.0f);
  u.boundsMin = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.min, 0.0f);
  u.boundsMax = glm::vec4(bounds.empty() ? glm::vec3(1.0f) : bounds.max, 0.0f);
  u.flags = glm::uvec4(static_cast<uint32_t>(s.target), scene.lightCount, s.raw ? 1 : 0, 0);
  u.written = glm::uvec4(gbufferWrites(s, scene), tuning.clusterTile, 0, 0);
  // The cluster grid: the clustered technique's, and the clusters view's whatever the technique.
  const ClusterGrid g = clusterGrid({s.width, s.height}, tuning);
  u.grid = glm::uvec4(g.x, g.y, g.slices, static_cast<uint32_t>(s.technique));
  float slicesPerLog = float(g.slices) / std::log(s.camera.farPlane / s.camera.nearPlane);
  u.slicing = glm::vec4(slicesPerLog, std::log(s.camera.nearPlane) * slicesPerLog,
                        float(s.heatMapMax > 0 ? s.heatMapMax : kDefaultHeatMapMax), float(s.time));
  // The sky ignores the rotation: its orientation is the sun's.
  const float rotation =
      s.environment.mode == EnvironmentMode::Hdr ? s.environment.rotation : 0.0f;
  u.environment = glm::vec4(float(static_cast<uint32_t>(s.environment.mode)),
                            s.environment.intensity, s.environment.background ? 1.0f : 0.0f, 0.0f);
  u.environmentRotation = glm::vec4(std::cos(rotation), std::sin(rotation), 0.0f, 0.0f);
  u.post = glm::uvec4(static_cast<uint32_t>(s.antialiased() ? s.antialias : Antialias::None),
                      s.markers ? 1 : 0, 0, 0);
  if (sunShadow) {
    u.sunShadowMatrix = sunShadow->mapFromWorld;
    // Offset: a texel along the normal (more at grazing angles, frame.glsl); bias: a texel of
    // depth (the map's depth range is as deep as it is wide), scaled by the slope there.
    u.sunShadow = glm::vec4(1.0f, sunShadow->texelWorld, 1.0f / float(s.shadows.mapSize),
                            1.0f / float(s.shadows.mapSize));
  }
  if (!lightShadows.empty()) {
    u.lightShadows = glm::uvec4(uint32_t(lightShadows.lights.size()), lightShadows.tileSize,
                                lightShadows.atlas.width, lightShadows.atlas.height);
    for (size_t i = 0; i < lightShadows.lights.size(); ++i) {
      u.shadowedLightIndex[i / 4][int(i % 4)] = lightShadows.lights[i];
      u.lightShadow[i] = lightShadows.shadows[i];
    }
  }
  technique.writeUniforms(u);
  stochastic.writeUniforms(u, s, scene);
  slot.shadingFeatures = shadingFeatures(u, scene);
  std::memcpy(slot.uniforms.mapped, &u, sizeof(u));
}

Renderer::Renderer(gpu::Context& context, const Tuning& tuning)
    : state_(std::make_unique<State>(context, tuning)) {
  State& s = *state_;
  VkDevice device = context.device;
  const std::vector<State::FrameSlot*> slots = s.allSlots();
  for (State::FrameSlot* slot : slots) {
    // Transfer destination: a multi-target frame rewrites its view index on the GPU timeline
    // between its views (render/extra_targets.h).
    slot->uniforms = s.uniformArena.createBuffer(
        sizeof(FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        gpu::MemoryUse::Upload);
    slot->counters = s.uniformArena.createBuffer(
        sizeof(CullingStats), VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUse::Readback);
    slot->recorder = gpu::createCommandRecorder(context);
  }
  s.recorder = gpu::createCommandRecorder(context);
  s.environmentPasses = std::make_unique<EnvironmentPasses>(context, s.recorder);

  VkSamplerCreateInfo samplerInfo{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_NEAREST;
  samplerInfo.addressModeU = samplerInfo.addressModeV = samplerInfo.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VK_CHECK(vkCreateSampler(device, &samplerInfo, nullptr, &s.sampler));
  samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_LINEAR;
  VK_CHECK(vkCreateSampler(device, &samplerInfo, nullptr, &s.linearSampler));

  // Sets 0 (scene) and 1 (targets, twice: rawTargetSet) of every frame slot; each technique
  // allocates its own set 2.
  const auto n = static_cast<uint32_t>(slots.size());
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, n * 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, n * 12},  // + the edge pixels, the YCbCr planes, the cluster marks (set 1, twice)
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, n * 22},  // + the shadow maps, the LDR target
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, n * 10},
                                  {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, n * 2}};  // lights, materials
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 3 * n;
  poolInfo.poolSizeCount = 5;
  poolInfo.pPoolSizes = sizes;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &s.descriptorPool));
  std::vector<VkDescriptorSetLayout> layouts;
  for (uint32_t i = 0; i < n; ++i) {
    layouts.push_back(s.pipelines.sceneSetLayout);
    layouts.push_back(s.pipelines.targetSetLayout);
    layouts.push_back(s.pipelines.targetSetLayout);
  }
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = s.descriptorPool;
  alloc.descriptorSetCount = 3 * n;
  alloc.pSetLayouts = layouts.data();
  std::vector<VkDescriptorSet> sets(3 * n);
  VK_CHECK(vkAllocateDescriptorSets(device, &alloc, sets.data()));
  for (uint32_t i = 0; i < n; ++i) {
    slots[i]->sceneSet = sets[3 * i];
    slots[i]->targetSet = sets[3 * i + 1];
    slots[i]->rawTargetSet = sets[3 * i + 2];
  }
}

Renderer::~Renderer() {
  State& s = *state_;
  vkDeviceWaitIdle(s.context.device);
  // Pixels lent out are being encoded: wait for them (bounded) before their memory goes.
  for (int i = 0; i < 10000; ++i) {
    const bool lent = std::any_of(s.readbacks.begin(), s.readbacks.end(), [](const auto& r) {
      return r->held.load(std::memory_order_acquire);
    });
    if (!lent) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  s.readbacks.clear();
  for (State::FrameSlot* slot : s.allSlots()) {
    slot->targets.reset();
    slot->visibility.reset();
    gpu::destroyCommandRecorder(s.context, slot->recorder);
  }
  s.splitTechniques.clear();
  s.techniques.clear();
  s.scenes.clear();
  s.environments.clear();
  s.environmentPasses.reset();
  vkDestroyDescriptorPool(s.context.device, s.descriptorPool, nullptr);
  vkDestroySampler(s.context.device, s.sampler, nullptr);
  vkDestroySampler(s.context.device, s.linearSampler, nullptr);
  gpu::destroyCommandRecorder(s.context, s.recorder);
}

SceneId Renderer::createScene(const scene::Scene& scene) {
  State& s = *state_;
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene,
                                                s.pipelines.materialSetLayout);
  SceneId id = s.nextSceneId++;
  s.scenes.emplace(id, std::move(buffers));
  return id;
}

void Renderer::replaceScene(SceneId id, const scene::Scene& scene) {
  State& s = *state_;
  s.scene(id);  // throws for an unknown id
  s.quiesce();  // frames in flight may draw the old buffers
  // Build the new buffers before dropping the old, so a failure leaves the old scene in place.
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene,
                                                s.pipelines.materialSetLayout);
  s.scenes[id] = std::move(buffers);
  s.costs.erase(id);  // another model: another cost
}

void Renderer::destroyScene(SceneId id) {
  State& s = *state_;
  s.scene(id);  // throws for an unknown id
  s.quiesce();
  s.scenes.erase(id);
  s.environments.erase(id);
  s.costs.erase(id);
}

void Renderer::setEnvironmentImage(SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) {
  state_->quiesce();
  state_->environment(id).setImage(std::move(image));
}

uint64_t Renderer::environmentRebuilds(SceneId id) const {
  state_->scene(id);
  auto it = state_->environments.find(id);
  return it == state_->environments.end() ? 0 : it->second->rebuilds;
}

void Renderer::updateLights(SceneId id, const LightUpdate& update) {
  state_->quiesce();  // frames in flight read the buffers the edit writes (or replaces)
  state_->scene(id).updateLights(state_->recorder, update);
}

void Renderer::updateInstances(SceneId id, const InstanceUpdate& update) {
  state_->quiesce();
  state_->scene(id).updateInstances(state_->recorder, update);
}

void Renderer::updateMaterials(SceneId id, const std::vector<MaterialWrite>& writes) {
  state_->quiesce();
  state_->scene(id).updateMaterials(state_->recorder, writes);
}

bool Renderer::hasScene(SceneId id) const { return state_->scenes.contains(id); }

uint32_t Renderer::lightCount(SceneId id) const { return state_->scene(id).lightCount; }

uint64_t Renderer::sceneBytes(SceneId id) const {
  auto it = state_->environments.find(id);
  return state_->scene(id).bytes() + (it == state_->environments.end() ? 0 : it->second->bytes());
}

uint32_t Renderer::State::pickSlot(const FrameSettings& settings) const {
  uint32_t best = framesInFlight;
  int bestRank = -1;
  double bestDistance = 0.0;
  const double pixels = double(settings.width) * settings.height;
  for (uint32_t i = 0; i < framesInFlight; ++i) {
    const FrameSlot& slot = *slots[i];
    if (slot.inFlight) continue;
    const FrameTargets* t = slot.targets.get();
    // 2: its targets fit as they are; 1: it has none; 0: they would be made again.
    const int rank = !t ? 1 : targetsFit(*t, {settings.width, settings.height}, settings.raw) ? 2 : 0;
    // Of targets made again, those nearest in size: an interactive frame whose scale changed
    // takes the slot of the interactive frames before it, not the still's.
    const double distance =
        t ? std::abs(std::log(double(t->extent.width) * t->extent.height / pixels)) : 0.0;
    const bool better =
        best == framesInFlight || rank > bestRank ||
        (rank == bestRank && (distance < bestDistance ||
                              (distance == bestDistance && slot.lastUsed < slots[best]->lastUsed)));
    if (better) {
      best = i;
      bestRank = rank;
      bestDistance = distance;
    }
  }
  return best;
}

void Renderer::releaseFrameMemory(uint64_t keepBytes) {
  State& s = *state_;
  // Slots not in flight: nothing on the GPU uses their targets; the target descriptor set points
  // at freed views until ensureTargets() makes new ones and writes it again. Frames in flight,
  // and an unfinished split frame, keep their own.
  s.quiesce();
  // The slot of the last whole frame may stay (keepBytes): its targets, sun map and one readback
  // buffer of its size, when together they hold at most keepBytes.
  State::FrameSlot* kept = nullptr;
  VkDeviceSize keptReadback = 0;
  if (keepBytes > 0) {
    for (auto& slot : s.slots) {
      if (slot->lastUsed > 0 && (!kept || slot->lastUsed > kept->lastUsed)) kept = slot.get();
    }
    if (kept && kept->targets) {
      keptReadback = State::readbackBytes(kept->settings);
      const uint64_t bytes = kept->targets->bytesAllocated() +
                             kept->shadows->gpuMemoryBytes() + keptReadback;
      if (bytes > keepBytes) kept = nullptr;
    } else {
      kept = nullptr;
    }
  }
  for (auto& slot : s.slots) {
    if (slot->inFlight || slot.get() == kept) continue;
    slot->targets.reset();
    slot->shadows->release();
  }
  if (!s.splitBusy) {
    s.split.targets.reset();
    s.split.shadows->release();
  }
  s.trimReadbacks(kept ? keptReadback : 0);
}

Renderer::State::PooledReadback* Renderer::State::acquireReadback(VkDeviceSize bytes) {
  PooledReadback* free = nullptr;
  size_t count = 0;
  // The sizes of the frames the slots' targets were last made for: a stream's still and its
  // interactive frames alternate, each in its slot, and each keeps its buffer.
  auto slotsUse = [&](VkDeviceSize size) {
    return std::any_of(slots.begin(), slots.end(), [&](const auto& slot) {
      return slot->targets && readbackBytes(slot->settings) == size;
    });
  };
  for (auto it = readbacks.begin(); it != readbacks.end();) {
    PooledReadback& r = **it;
    const bool held = r.held.load(std::memory_order_acquire);
    if (!held && r.bytes != bytes && !slotsUse(r.bytes)) {
      it = readbacks.erase(it);  // another size: nothing uses it (frames in flight hold theirs)
      continue;
    }
    if (!held && r.bytes == bytes && !free) free = &r;
    ++count;
    ++it;
  }
  if (!free && count >= kMaxPooledReadbacks) {
    // Full: a free buffer of another size goes to make room.
    auto other = std::find_if(readbacks.begin(), readbacks.end(), [&](const auto& r) {
      return r->bytes != bytes && !r->held.load(std::memory_order_acquire);
    });
    if (other != readbacks.end()) {
      readbacks.erase(other);
      --count;
    }
  }
  if (!free && count < kMaxPooledReadbacks) {
    auto made = std::make_unique<PooledReadback>();
    made->arena = std::make_unique<gpu::Arena>(context, bytes);
    made->buffer = made->arena->createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                             gpu::MemoryUse::Readback);
    made->bytes = bytes;
    free = made.get();
    readbacks.push_back(std::move(made));
  }
  if (free) free->held.store(true, std::memory_order_relaxed);
  return free;
}

void Renderer::State::trimReadbacks(VkDeviceSize keep) {
  bool keeping = keep > 0;
  std::erase_if(readbacks, [&](const std::unique_ptr<PooledReadback>& r) {
    if (r->held.load(std::memory_order_acquire)) return false;
    if (keeping && r->bytes == keep) {
      keeping = false;
      return false;
    }
    return true;
  });
}

void Renderer::setGpuTimestamps(GpuTimestamps mode) {
  for (State::FrameSlot* slot : state_->allSlots()) {
    slot->timer->setFrameOnly(mode == GpuTimestamps::Frame);
    slot->timer->setOff(mode == GpuTimestamps::None);
  }
}

uint64_t Renderer::gpuMemoryBytes() const {
  const State& s = *state_;
  uint64_t total = s.uniformArena.bytesAllocated();
  for (const auto& [id, scene] : s.scenes) total += scene->bytes();
  for (const auto& [id, env] : s.environments) total += env->bytes();
  total += s.environmentPasses->gpuMemoryBytes();
  for (const State::FrameSlot* slot : const_cast<State&>(s).allSlots()) {
    if (slot->targets) total += slot->targets->bytesAllocated();
    total += slot->shadows->gpuMemoryBytes();
    if (slot->visibility) total += slot->visibility->arena.bytesAllocated();
  }
  for (const auto& technique : s.techniques) total += technique->gpuMemoryBytes();
  total += s.stochastic.gpuMemoryBytes();
  for (const auto& technique : s.splitTechniques) {
    if (technique) total += technique->gpuMemoryBytes();
  }
  for (const auto& readback : s.readbacks) total += readback->arena->bytesAllocated();
  return total;
}

void Renderer::limitListMemory(uint64_t bytes, uint64_t startBytes) {
  state_->quiesce();
  for (const auto& technique : state_->techniques) technique->limitListMemory(bytes, startBytes);
  for (const auto& technique : state_->splitTechniques) {
    if (technique) technique->limitListMemory(bytes, startBytes);
  }
}

uint32_t Renderer::maxDimension() const { return state_->context.info.maxImageDimension2D; }

namespace {

// Label frames are read back raw (Target::InstanceId's comment). Motion is drawn into the
// frame's own output (render/motion.h): never one of a multi-target frame's extras.
void checkLabels(const FrameSettings& settings) {
  if (std::find(settings.alsoRead.begin(), settings.alsoRead.end(), Target::Motion) !=
      settings.alsoRead.end()) {
    throw std::invalid_argument("motion is drawn into the frame's output: it is read as the "
                                "frame's target, not among alsoRead");
  }
  if (isLabel(settings.target) && !settings.raw) {
    throw std::invalid_argument("a label target (" + std::string(targetName(settings.target)) +
                                ") is read back raw: FrameSettings::raw must be set");
  }
}

void checkSize(const FrameSettings& settings, uint32_t maxDimension) {
  if (settings.width == 0 || settings.height == 0 || settings.width > maxDimension ||
      settings.height > maxDimension) {
    throw std::invalid_argument("frame size " + std::to_string(settings.width) + "x" +
                                std::to_string(settings.height) + " is outside 1.." +
                                std::to_string(maxDimension));
  }
}

double pixelsOf(const FrameSettings& settings) {
  return double(settings.width) * double(settings.height);
}

}  // namespace

std::optional<SunShadowFit> Renderer::State::sunShadowFor(const SceneBuffers& scene,
                                                          const FrameSettings& settings) {
  if (!settings.shadows.sun || settings.sun.intensity <= 0.0f || scene.draws.empty()) {
    return std::nullopt;
  }
  if (tracesLocalShadows(settings)) return std::nullopt;  // traced instead (stochastic_shadows.h)
  return fitSunShadow(scene.bounds, settings.sun.direction, settings.shadows.mapSize);
}

// The scene's environment when the frame uses one; throws for hdr without an image.
SceneEnvironment* Renderer::State::environmentFor(SceneId id, const FrameSettings& settings) {
  if (settings.environment.mode == EnvironmentMode::None) return nullptr;
  SceneEnvironment* env = &environment(id);
  EnvironmentPasses::inputsFor(settings, *env);  // throws for hdr without an image
  return env;
}

Frame Renderer::render(SceneId id, const FrameSettings& settings) {
  return finishFrame(beginFrame(id, settings));
}

void Renderer::setFramesInFlight(uint32_t frames) {
  State& s = *state_;
  for (const auto& slot : s.slots) {
    if (slot->inFlight) throw std::logic_error("frames are in flight");
  }
  s.framesInFlight = std::clamp(frames, 1u, kMaxFramesInFlight);
}

uint32_t Renderer::framesInFlight() const { return state_->framesInFlight; }

void Renderer::setOverlap(bool overlap) { state_->overlap = overlap; }

void Renderer::setGBufferPath(GBufferPath path) { state_->gbufferPath = path; }

bool Renderer::canBegin() const {
  const State& s = *state_;
  for (uint32_t i = 0; i < s.framesInFlight; ++i) {
    if (!s.slots[i]->inFlight) return true;
  }
  return false;
}

uint32_t Renderer::beginFrame(SceneId id, const FrameSettings& settings) {
  State& s = *state_;
  SceneBuffers& scene = s.scene(id);
  checkSize(settings, maxDimension());
  checkLabels(settings);
  s.technique(settings.technique);  // throws for an unknown technique
  SceneEnvironment* environment = s.environmentFor(id, settings);
  const uint32_t index = s.pickSlot(settings);
  if (index == s.framesInFlight) throw std::logic_error("every frame slot is in flight");
  State::FrameSlot& slot = *s.slots[index];
  slot.lastUsed = ++s.framesBegun;
  // The host may change what frames in flight use: wait for them first (Renderer's comment).
  const State::Shape shape{settings.technique, settings.width, settings.height, settings.raw,
                           scene.lightCount};
  const bool rebuildsEnvironment =
      environment != nullptr &&
      environment->built != EnvironmentPasses::inputsFor(settings, *environment);
  if (shape != s.lastShape || rebuildsEnvironment) s.quiesce();
  s.lastShape = shape;
  bool sharesScene = false;  // with a frame in flight
  for (const auto& other : s.slots) sharesScene = sharesScene || (other->inFlight && other->scene == id);
  const auto start = std::chrono::steady_clock::now();
  slot.times = {};
  // Borrowed pixels: a pooled buffer of their own, lent out with the frame; when every one is
  // lent out, the slot's own buffer and a copy on the render thread.
  const VkDeviceSize readbackBytes = State::readbackBytes(settings);
  slot.readback = readbackBytes > 0 ? s.acquireReadback(readbackBytes) : nullptr;
  try {
    s.recordFrame(slot, scene, environment, settings, !s.overlap || sharesScene);
    gpu::submit(s.context, slot.recorder);
  } catch (...) {
    if (slot.readback) slot.readback->held.store(false, std::memory_order_release);
    slot.readback = nullptr;
    throw;
  }
  slot.times.recordMs = Milliseconds(std::chrono::steady_clock::now() - start).count();
  slot.inFlight = true;
  slot.scene = id;
  slot.settings = settings;
  return index;
}

bool Renderer::frameDone(uint32_t index) const {
  const State& s = *state_;
  return index < s.slots.size() && s.slots[index]->inFlight &&
         vkGetFenceStatus(s.context.device, s.slots[index]->recorder.fence) == VK_SUCCESS;
}

bool Renderer::waitFrame(uint32_t index, uint64_t timeoutNs) const {
  const State& s = *state_;
  if (index >= s.slots.size() || !s.slots[index]->inFlight) return false;
  const auto start = std::chrono::steady_clock::now();
  const VkResult result =
      vkWaitForFences(s.context.device, 1, &s.slots[index]->recorder.fence, VK_TRUE, timeoutNs);
  s.slots[index]->times.fenceWaitMs += Milliseconds(std::chrono::steady_clock::now() - start).count();
  if (result == VK_TIMEOUT) return false;
  VK_CHECK(result);
  return true;
}

// Reads the frame back; when the technique's lists overflowed but may still grow, grows them and
// renders the frame once more: a frame with lights missing is never the answer while memory
// allows.
Frame Renderer::finishFrame(uint32_t index) {
  State& s = *state_;
  if (index >= s.slots.size() || !s.slots[index]->inFlight) {
    throw std::logic_error("frame slot " + std::to_string(index) + " is not in flight");
  }
  State::FrameSlot& slot = *s.slots[index];
  struct Free {  // the slot is free once this returns or throws
    State::FrameSlot& slot;
    ~Free() { slot.inFlight = false; }
  } free{slot};
  const auto waitStart = std::chrono::steady_clock::now();
  gpu::waitFor(s.context, slot.recorder);
  slot.times.fenceWaitMs += Milliseconds(std::chrono::steady_clock::now() - waitStart).count();
  const FrameSettings& settings = slot.settings;
  LightingTechnique& technique = s.technique(settings.technique);
  Frame frame;
  try {
    frame = s.readFrame(slot, slot.meta, settings, technique);
  } catch (...) {
    if (slot.readback) slot.readback->held.store(false, std::memory_order_release);
    slot.readback = nullptr;
    throw;
  }
  slot.readback = nullptr;  // the frame's now (or given back if it was not lent out)
  // Frames finish in the order they were submitted: the GPU idled between the previous one's
  // last timestamp and this one's first.
  if (frame.times.gpuMs >= 0.0) {
    if (s.lastGpuEndTick != 0 && slot.timer->firstTick() >= s.lastGpuEndTick) {
      frame.times.gpuIdleMs = double(slot.timer->firstTick() - s.lastGpuEndTick) *
                              s.context.info.timestampPeriodNs * 1e-6;
    } else if (s.lastGpuEndTick != 0) {
      frame.times.gpuIdleMs = 0.0;  // it started before the previous one ended (overlap)
    }
    s.lastGpuEndTick = std::max(s.lastGpuEndTick, slot.timer->lastTick());
  }
  if (s.scenes.contains(slot.scene)) {
    // What the frame cost, for shouldSplit: its GPU time (without timestamps, what the host
    // recorded and waited for).
    const double ms = frame.times.gpuMs >= 0.0 ? frame.times.gpuMs
                                               : frame.times.recordMs + frame.times.fenceWaitMs;
    s.costs[slot.scene] = {settings.technique, pixelsOf(settings), frame.lightCount, ms};
  }
  if (s.scenes.contains(slot.scene) && technique.growLists(frame.culling)) {
    // The lists are reallocated: nothing in flight may use them.
    s.quiesce();
    try {
      SceneBuffers& scene = s.scene(slot.scene);
      Frame regrown = s.renderOnce(slot, scene, s.environmentFor(slot.scene, settings), settings);
      regrown.culling.listsGrew = true;
      return regrown;
    } catch (const gpu::VulkanError&) {
      // Out of device memory for the larger lists: answer with the frame we have (its overflow
      // is reported).
      technique.growthFailed();
    }
  }
  return frame;
}

// Fits the slot's targets and the technique's buffers to the frame; writes its uniforms and set 0.
bool Renderer::State::prepareFrame(FrameSlot& slot, SceneBuffers& scene,
                                   SceneEnvironment* environment, const FrameSettings& settings,
                                   LightingTechnique& technique) {
  VkExtent2D extent{settings.width, settings.height};
  applyPoses(scene, settings);  // before anything reads the scene's bounds or draws
  const bool madeTargets = ensureTargets(slot, extent, settings.raw);
  if (settings.drawsLabels()) slot.targets->ensureLabels();
  if (const ExtraRegions extras = extraRegionsOf(settings); extras.count > 0) {
    slot.targets->ensureExtras(extras.count);
    if (!settings.raw) writeRawTargetSet(slot);
  }
  technique.prepare(extent, scene.lightCount);
  // The sun's shadow map: fitted to this scene and sun, rendered this frame when on.
  const std::optional<SunShadowFit> sunShadow = sunShadowFor(scene, settings);
  if (sunShadow) {
    slot.shadows->ensureSun(settings.shadows.mapSize);
  } else {
    slot.shadows->ensureSunPlaceholder();
  }
  // The local lights' maps: which lights get one this frame, their tiles in the atlas.
  slot.lightShadows = planLightShadows(scene.shadowCasters, settings);
  if (slot.lightShadows.empty()) {
    slot.shadows->ensureAtlasPlaceholder();
  } else {
    slot.shadows->ensureAtlas(slot.lightShadows.atlas);
  }
  writeUniforms(slot, settings, scene, technique, sunShadow ? &*sunShadow : nullptr,
                slot.lightShadows);
  writeSceneSet(slot, scene, environment ? environment->lighting : environmentPasses->brdfLut());
  return madeTargets;
}

namespace {

// Everything submitted before (earlier frames on the queue included) happens before what follows.
void waitForEarlier(VkCommandBuffer cmd) {
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

}  // namespace

// Begins the slot's command buffer with its sets 0 and 1 bound for graphics and compute and its
// timer reset. The first command waits for everything submitted before (frames in flight share
// the scenes' lights, the techniques' lists and counters, and write them without other
// barriers); the frames' host work overlaps, their GPU work runs in order.
VkCommandBuffer Renderer::State::beginFrameCommands(FrameSlot& slot, bool waitAtStart) {
  VkCommandBuffer cmd = gpu::beginCommands(context, slot.recorder);
  if (waitAtStart) waitForEarlier(cmd);
  VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines.layout, 0, 2, sets, 0,
                          nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelines.layout, 0, 2, sets, 0,
                          nullptr);
  slot.timer->reset(cmd);
  return cmd;
}

// environment (when its inputs changed), animate (or restoring the origins), shadow, gbuffer.
void Renderer::State::recordBeforeLighting(VkCommandBuffer cmd, FrameSlot& slot,
                                           SceneBuffers& scene, SceneEnvironment* environment,
                                           const FrameSettings& settings) {
  State& s = *this;
  const Pipelines& p = s.pipelines;
  if (slot.targets->clusterMarksFresh) {
    // New targets: no cluster marked (later frames leave them so; FrameTargets).
    vkCmdFillBuffer(cmd, slot.targets->clusterMarks.buffer, 0, VK_WHOLE_SIZE, 0u);
    gpu::bufferBarrier(cmd, slot.targets->clusterMarks, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    slot.targets->clusterMarksFresh = false;
  }
  if (environment) {
    const SceneEnvironment::Inputs inputs = EnvironmentPasses::inputsFor(settings, *environment);
    if (environment->built != inputs) {
      slot.timer->beginPass(cmd, "environment");
      environmentPasses->record(cmd, *environment, inputs);
      // The environment passes bound their own layout's set 0; the frame's sets go back.
      VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
    }
  }

  // Skinned and morphed instances posed (when the pose changed), before anything draws them.
  if (const bool previous = settings.target == Target::Motion && settings.previousPose != nullptr;
      SkinningPass::needed(scene, previous)) {
    skinning.record(cmd, scene, previous, *slot.timer);
    // It bound its own layout's set; the frame's go back.
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  }
  if (StochasticShadows::wanted(settings)) {
    // The BVH of the posed triangles, for the shadow rays of the lighting.
    stochastic.recordBvh(cmd, scene, *slot.timer);
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  }
  if (settings.animate) {
    // Or the lighting technique moves them, while it walks them (LightingPass::animateLights).
    if (!s.technique(settings.technique).animatesLights()) {
      slot.timer->beginPass(cmd, "animate");
      recordAnimateLights(cmd, p, scene);
    }
    scene.lightsMoved = true;
  } else if (scene.lightsMoved) {
    recordRestoreLights(cmd, scene);
    scene.lightsMoved = false;
  }
  if (const std::optional<SunShadowFit> sunShadow = sunShadowFor(scene, settings)) {
    // Drawn again only when the scene or the fit changed (ShadowMaps::sunHolds): not for a camera
    // move, a light, material or slider change, or animated lights.
    // After a few objects moved, only the texels under their old and new places (repairSun).
    slot.sunMap = Frame::SunMap::kept;
    if (!slot.shadows->sunHolds(scene, sunShadow->viewProjection)) {
      slot.timer->beginPass(cmd, "shadow");
      slot.sunMap = Frame::SunMap::repaired;
      if (!slot.shadows->repairSun(cmd, p, scene, sunShadow->viewProjection)) {
        slot.shadows->recordSun(cmd, p, scene, sunShadow->viewProjection);
        slot.sunMap = Frame::SunMap::drawn;
      }
    }
  } else {
    slot.sunMap = Frame::SunMap::none;
    slot.shadows->recordSunUnused(cmd);
  }
  if (!slot.lightShadows.empty()) {
    slot.timer->beginPass(cmd, "light-shadows");
    slot.shadows->recordLights(cmd, p, scene, slot.lightShadows);
  } else {
    slot.shadows->recordAtlasUnused(cmd);
  }
  if (computeGBufferFor(scene, settings)) {
    computeGBuffer.record(cmd, slot.visibility, *slot.targets, scene, slot.sceneSet, *slot.timer);
    // Its passes bound their own layout's sets; the frame's go back.
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  } else {
    slot.timer->beginPass(cmd, "gbuffer");
    recordGBufferPass(cmd, p, *slot.targets, scene, gbufferWrites(settings, scene),
                      MeshDetail::of(settings));
    if (settings.drawsLabels()) {
      slot.timer->beginPass(cmd, "labels");
      recordLabelPass(cmd, p, *slot.targets, scene, MeshDetail::of(settings));
    }
    if (settings.target == Target::Motion) {
      slot.timer->beginPass(cmd, "motion");  // names-once: the pass, not the target
      const scene::Camera& previous = settings.previousCamera.value_or(settings.camera);
      const float aspect = float(settings.width) / float(settings.height);
      motion.record(cmd, *slot.targets, scene, slot.sceneSet,
                    scene::projectionMatrix(previous, aspect) * scene::viewMatrix(previous),
                    settings.previousPose != nullptr, MeshDetail::of(settings));
      // Its layout is not the frame's: the frame's sets go back.
      VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 2, sets, 0, nullptr);
    }
  }
}

void Renderer::State::applyPoses(SceneBuffers& scene, const FrameSettings& settings) {
  if (settings.pose && scene.poseDiffers(*settings.pose)) {
    quiesce();
    scene.applyPose(recorder, settings.pose);
  }
  if (settings.target == Target::Motion && settings.previousPose &&
      scene.previousDiffers(*settings.previousPose)) {
    quiesce();
    scene.applyPrevious(recorder, settings.previousPose);
  }
}

uint32_t Renderer::State::afterUnits(AfterStep step, const FrameSlot& slot,
                                     const SceneBuffers& scene,
                                     const FrameSettings& settings) const {
  // A label frame: the label pass drew everything it shows; its image is the output. The
  // motion pass, likewise, drew the output.
  const bool label = isLabel(settings.target) || settings.target == Target::Motion;
  switch (step) {
    case kForward:
      return !label && (hasBlendDraws(scene) || settings.markers) ? 1u : 0u;
    case kFinal: {
      if (label) return 0;
      const VkExtent2D groups = finalPassGroups(pipelines, *slot.targets, settings.target);
      return groups.width * groups.height;
    }
    case kAntialias:
      return label ? 0u : 1u;
    default:
      return 1;
  }
}

// blend (alpha-BLEND draws), markers | final | antialias, overlay, the counters' copy | readback.
void Renderer::State::recordAfterStep(VkCommandBuffer cmd, const FrameSlot& slot,
                                      SceneBuffers& scene, const FrameSettings& settings,
                                      LightingTechnique& technique, AfterLayouts& layouts,
                                      AfterStep step, uint32_t first, uint32_t count) {
  const Pipelines& p = pipelines;
  const FrameTargets& t = *slot.targets;
  const bool antialias = settings.antialiased();  // as FrameUniforms.post.x says
  switch (step) {
    case kForward:
      if (hasBlendDraws(scene)) {
        slot.timer->beginPass(cmd, "blend");
        layouts.hdr = recordBlendPass(cmd, p, t, scene, scene::viewMatrix(settings.camera),
                                      layouts.hdr, technique.bindForwardLights(cmd));
      }
      if (settings.markers) {
        slot.timer->beginPass(cmd, "markers");
        recordMarkerPass(cmd, p, t, scene);
      }
      break;
    case kFinal:
      slot.timer->beginPass(cmd, "final");  // names-once: the pass, not the target
      recordFinalPass(cmd, p, t, settings.target, settings.markers, antialias, layouts.hdr,
                      layouts.lighting, first, count);
      break;
    case kAntialias:
      if (antialias) {
        slot.timer->beginPass(cmd, "antialias");
        recordAntialiasPass(cmd, p, t);
      }
      if (settings.target == Target::LightVolumes && !settings.raw) {
        slot.timer->beginPass(cmd, "overlay");
        recordLightVolumeOverlayPass(cmd, p, t, scene);
        layouts.output = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
      }
      if (const gpu::Buffer* counters = technique.counters()) {
        // The frame's own copy of the culling counters: the next frame in flight resets the
        // technique's (record() made them readable by a copy).
        const VkBufferCopy region{0, 0, sizeof(CullingStats)};
        vkCmdCopyBuffer(cmd, counters->buffer, slot.counters.buffer, 1, &region);
        gpu::bufferBarrier(cmd, slot.counters, VK_PIPELINE_STAGE_2_COPY_BIT,
                           VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                           VK_ACCESS_2_HOST_READ_BIT);
      }
      break;
    case kReadback: {
      const gpu::Buffer& readback = slot.readback ? slot.readback->buffer : t.readback;
      if (isLabel(settings.target)) {
        slot.timer->beginPass(cmd, "readback");
        recordLabelReadback(cmd, t, readback);
      } else if (settings.yuv420Readback()) {
        slot.timer->beginPass(cmd, "yuv");
        recordYuv420Readback(cmd, pipelines, t, readback);
      } else {
        slot.timer->beginPass(cmd, "readback");
        recordReadback(cmd, t,
                       settings.target == Target::Motion ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL
                                                         : layouts.output,
                       readback);
      }
      if (!settings.alsoRead.empty()) {
        // A multi-target frame: its other targets from this same render.
        slot.timer->beginPass(cmd, "extra-targets");
        uint32_t hostFlags[4];
        std::memcpy(hostFlags,
                    static_cast<const uint8_t*>(slot.uniforms.mapped) + offsetof(FrameUniforms, flags),
                    sizeof hostFlags);
        recordExtraTargets(cmd, p, t, settings, slot.uniforms, offsetof(FrameUniforms, flags),
                           hostFlags, p.layout, slot.rawTargetSet);
      }
      break;
    }
    default:
      throw std::logic_error("no step " + std::to_string(step) + " after the lighting");
  }
}

void Renderer::State::recordAfterLighting(VkCommandBuffer cmd, const FrameSlot& slot,
                                          SceneBuffers& scene, const FrameSettings& settings,
                                          LightingTechnique& technique,
                                          VkImageLayout lightingLayout) {
  AfterLayouts layouts{lightingLayout, lightingLayout};
  for (uint32_t step = 0; step < kAfterSteps; ++step) {
    const uint32_t units = afterUnits(AfterStep(step), slot, scene, settings);
    if (units > 0) {
      recordAfterStep(cmd, slot, scene, settings, technique, layouts, AfterStep(step), 0, units);
    }
  }
  slot.timer->end(cmd);
}

Frame Renderer::State::metaOf(const SceneBuffers& scene, const SceneEnvironment* environment,
                              const FrameSettings& settings) {
  Frame meta;
  meta.technique = settings.technique;
  meta.lightCount = scene.lightCount;
  meta.sceneBytes = scene.bytes() + (environment ? environment->bytes() : 0);
  meta.culling.lightBytes = scene.lights.size + scene.lightOrigins.size;
  return meta;
}

// After the last submission: the pixels and what the frame reports (passes: the last
// submission's; a split frame sums its own).
Frame Renderer::State::readFrame(const FrameSlot& slot, const Frame& meta,
                                 const FrameSettings& settings, LightingTechnique& technique) {
  const FrameTargets& t = *slot.targets;
  Frame frame = meta;
  frame.width = t.extent.width;
  frame.height = t.extent.height;
  frame.times = slot.times;
  frame.yuv420 = settings.yuv420Readback();
  const size_t bytes = frame.yuv420 ? yuv420Layout(t.extent.width, t.extent.height).bytes()
                                    : size_t(t.extent.width) * t.extent.height * 4;
  const auto copyStart = std::chrono::steady_clock::now();
  if (settings.raw) {
    frame.data.resize(size_t(t.extent.width) * t.extent.height * 4);
    std::memcpy(frame.data.data(), t.readback.mapped, frame.data.size() * sizeof(float));
  } else if (PooledReadback* pooled = slot.readback) {
    // Lent out: the encoder reads the mapped memory; dropping the frame gives it back.
    frame.borrowed = std::make_shared<const BorrowedPixels>(
        static_cast<const uint8_t*>(pooled->buffer.mapped), bytes,
        [pooled] { pooled->held.store(false, std::memory_order_release); });
  } else {
    frame.rgba.resize(bytes);
    std::memcpy(frame.rgba.data(), t.readback.mapped, frame.rgba.size());
  }
  readExtraTargets(t, settings, frame);
  frame.times.copyMs = Milliseconds(std::chrono::steady_clock::now() - copyStart).count();
  for (auto& [name, ms] : slot.timer->results()) frame.passes.push_back({name, ms});
  if (slot.timer->lastTick() > slot.timer->firstTick()) {
    frame.times.gpuMs = double(slot.timer->lastTick() - slot.timer->firstTick()) *
                        context.info.timestampPeriodNs * 1e-6;
  }
  technique.report(frame.culling, technique.counters() ? slot.counters.mapped : nullptr);
  frame.lightShadows = {slot.lightShadows.lights, slot.lightShadows.requested,
                        slot.lightShadows.dropped};
  frame.sunMap = slot.sunMap;
  return frame;
}

// The frame, top to bottom, in one submission. Every request (any view, any size, any technique)
// takes this path, or the same steps split (beginSplit).
void Renderer::State::recordFrame(FrameSlot& slot, SceneBuffers& scene,
                                  SceneEnvironment* environment, const FrameSettings& settings,
                                  bool waitAtStart) {
  LightingTechnique& technique = this->technique(settings.technique);
  const bool madeTargets = prepareFrame(slot, scene, environment, settings, technique);
  VkCommandBuffer cmd = beginFrameCommands(slot, waitAtStart);
  recordBeforeLighting(cmd, slot, scene, environment, settings);
  // The technique's lists and counters are shared by frames in flight: the earlier frames are
  // done with them (their lighting, blend pass and counter copy) before this one resets them.
  if (!waitAtStart) waitForEarlier(cmd);
  // Lighting leaves HDR and light counts as attachments (raster) or storage images (compute).
  LightingPass lighting{cmd, *slot.timer, *slot.targets, scene, slot.shadingFeatures,
                       settings.animate && technique.animatesLights(),
                       computeGBufferFor(scene, settings)};
  if (StochasticShadows::wanted(settings)) lighting.stochastic = &stochastic;
  const VkImageLayout lightingLayout = technique.record(lighting);
  recordAfterLighting(cmd, slot, scene, settings, technique, lightingLayout);
  slot.meta = metaOf(scene, environment, settings);
  slot.meta.madeTargets = madeTargets;
}

Frame Renderer::State::renderOnce(FrameSlot& slot, SceneBuffers& scene,
                                  SceneEnvironment* environment, const FrameSettings& settings) {
  recordFrame(slot, scene, environment, settings);
  gpu::submitAndWait(context, slot.recorder);
  return readFrame(slot, slot.meta, settings, this->technique(settings.technique));
}

double Renderer::estimateMilliseconds(SceneId id, const FrameSettings& settings) const {
  const State& s = *state_;
  const SceneBuffers& scene = s.scene(id);
  const auto it = s.costs.find(id);
  if (it == s.costs.end() || it->second.technique != settings.technique) return -1.0;
  const State::FrameCost& cost = it->second;
  const double lights = std::max(1.0, double(scene.lightCount));
  const double measuredLights = std::max(1.0, double(cost.lights));
  if (lights > measuredLights * kCostLightsRange || lights * kCostLightsRange < measuredLights) {
    return -1.0;
  }
  // Linear in the pixels; more lights than measured scale it up, fewer are not assumed cheaper.
  return cost.ms * pixelsOf(settings) / std::max(1.0, cost.pixels) *
         std::max(1.0, lights / measuredLights);
}

bool Renderer::shouldSplit(SceneId id, const FrameSettings& settings) const {
  const State& s = *state_;
  const double estimate = estimateMilliseconds(id, settings);
  if (estimate >= 0.0) return estimate > s.wholeFrameMs;
  const double lights = double(s.scene(id).lightCount);
  const double pixels = pixelsOf(settings);
  return lights > kUnmeasuredSplitLights || pixels > kUnmeasuredSplitPixels ||
         pixels * lights > kUnmeasuredSplitPixelLights;
}

bool Renderer::splitBusy() const { return state_->splitBusy; }

void Renderer::setSliceMilliseconds(double milliseconds) {
  state_->sliceMs = milliseconds;
  state_->wholeFrameMs = 2.0 * milliseconds;
}

void Renderer::setFrameBudgetMilliseconds(double milliseconds) {
  state_->frameBudgetMs = std::max(0.0, milliseconds);
}

Renderer::SplitFrame::~SplitFrame() { renderer_.state_->splitBusy = false; }

double Renderer::SplitFrame::Step::weightOf(uint32_t first, uint32_t count) const {
  if (weights.empty()) return double(count);
  double sum = 0.0;
  const size_t end = std::min<size_t>(weights.size(), size_t(first) + count);
  for (size_t i = first; i < end; ++i) sum += weights[i];
  return sum;
}

double Renderer::SplitFrame::projectedMilliseconds() const {
  double rest = 0.0;
  for (size_t i = step_; i < steps_.size(); ++i) {
    const Step& st = steps_[i];
    const uint32_t first = i == step_ ? nextUnit_ : 0;
    // Not measured (or only in ranges too short to tell): not counted.
    if (!st.measuredWell || first >= st.units) continue;
    rest += st.msPerWeight * st.weightOf(first, st.units - first);
  }
  return elapsedMs_ + rest;
}

std::unique_ptr<Renderer::SplitFrame> Renderer::beginSplit(SceneId id,
                                                           const FrameSettings& settings) {
  State& s = *state_;
  if (s.splitBusy) throw std::logic_error("another split frame is unfinished");
  s.quiesce();  // its parts are waited for one by one; frames in flight go first
  SceneBuffers& scene = s.scene(id);
  checkSize(settings, maxDimension());
  checkLabels(settings);
  LightingTechnique& technique = s.splitTechnique(settings.technique);
  SceneEnvironment* environment = s.environmentFor(id, settings);
  std::unique_ptr<SplitFrame> frame(new SplitFrame(*this, id, settings));
  s.splitBusy = true;  // until `frame` is destroyed

  s.prepareFrame(s.split, scene, environment, settings, technique);
  // The steps, recorded in order: everything before the lighting (one unit), the technique's
  // steps, the passes after it. Scene, environment and technique stay as they are until the
  // frame ends (the render thread runs no edit of its scene meanwhile).
  State* state = &s;
  SplitFrame* f = frame.get();
  SplitFrame::Step before;
  before.units = 1;
  before.record = [state, &scene, environment, f](VkCommandBuffer cmd, uint32_t, uint32_t) {
    state->recordBeforeLighting(cmd, state->split, scene, environment, f->settings_);
  };
  frame->steps_.push_back(std::move(before));
  frame->firstLightingStep_ = frame->steps_.size();
  const bool computeGBuffer = s.computeGBufferFor(scene, settings);
  const bool animate = settings.animate && technique.animatesLights();
  const bool traced = StochasticShadows::wanted(settings);
  auto lightingPass = [state, &scene, computeGBuffer, animate, traced](VkCommandBuffer cmd) {
    LightingPass pass{cmd, *state->split.timer, *state->split.targets, scene,
                      state->split.shadingFeatures, animate, computeGBuffer};
    pass.split = true;
    if (traced) pass.stochastic = &state->stochastic;
    return pass;
  };
  const std::vector<LightingTechnique::Step> lighting = technique.steps(lightingPass(VK_NULL_HANDLE));
  for (uint32_t i = 0; i < lighting.size(); ++i) {
    SplitFrame::Step step;
    step.units = step.declaredUnits = lighting[i].units;
    step.lightingStep = int(i);
    step.listsBuilt = technique.listsBuiltAfter(i);
    step.unitsAlike = lighting[i].unitsAlike;
    const char* name = lighting[i].name;
    step.record = [state, &technique, lightingPass, name, i](VkCommandBuffer cmd, uint32_t first,
                                                             uint32_t count) {
      const LightingPass pass = lightingPass(cmd);
      pass.timer.beginPass(cmd, name);
      technique.recordStep(pass, i, first, count);
    };
    frame->steps_.push_back(std::move(step));
  }
  frame->lightingLayout_ = frame->hdrLayout_ = technique.lightingLayout();
  for (uint32_t i = 0; i < State::kAfterSteps; ++i) {
    const auto after = State::AfterStep(i);
    SplitFrame::Step step;
    step.units = s.afterUnits(after, s.split, scene, settings);
    step.record = [state, &scene, &technique, f, after](VkCommandBuffer cmd, uint32_t first,
                                                        uint32_t count) {
      State::AfterLayouts layouts{f->lightingLayout_, f->hdrLayout_, f->outputLayout_};
      state->recordAfterStep(cmd, state->split, scene, f->settings_, technique, layouts, after,
                             first, count);
      f->hdrLayout_ = layouts.hdr;
      f->outputLayout_ = layouts.output;
    };
    frame->steps_.push_back(std::move(step));
  }
  // The first submission: everything before the lighting.
  s.runSplitPart(*frame);
  return frame;
}

void Renderer::State::runSplitPart(SplitFrame& frame) {
  using Step = SplitFrame::Step;
  const auto partStart = std::chrono::steady_clock::now();
  quiesce();
  // The slot's sets, uniforms and targets are as beginSplit left them: whole frames use their own.
  VkCommandBuffer cmd = beginFrameCommands(split);
  struct Range {
    Step* step;
    double weight;
    double plannedMs;  // 0: not measured yet
  };
  std::vector<Range> ranges;
  double plannedMs = 0.0;
  bool end = false;
  while (!end && frame.step_ < frame.steps_.size()) {
    Step& st = frame.steps_[frame.step_];
    if (frame.nextUnit_ >= st.units) {
      ++frame.step_;
      frame.nextUnit_ = 0;
      continue;
    }
    if (!st.weighed) {
      // The technique's weights read what the steps before this one made: they must have run.
      if (!ranges.empty() && st.units > 1) break;
      if (st.lightingStep >= 0 && st.units > 1) {
        const LightingTechnique& technique = splitTechnique(frame.settings_.technique);
        st.units = technique.unitsWithWork(uint32_t(st.lightingStep), st.units);
        st.weights = technique.unitWeights(uint32_t(st.lightingStep), split.targets->extent);
        if (st.weights.size() != st.units) st.weights.clear();
      }
      st.weighed = true;
      if (frame.nextUnit_ >= st.units) continue;  // nothing to do after all
    }
    const uint32_t remaining = st.units - frame.nextUnit_;
    uint32_t count = 0;
    if (st.msPerWeight > 0.0) {
      // As many units as fit in what is left of the slice, weighing at most kRangeGrowth times
      // the last range.
      const double room = sliceMs - plannedMs;
      const double most = std::max(st.lastRangeWeight, 1.0) *
                          (st.unitsAlike ? kRangeGrowthAlike : kRangeGrowthUnlike);
      if (st.weights.empty()) {
        count = uint32_t(std::clamp(std::floor(std::min(room / st.msPerWeight, most)), 0.0,
                                    double(remaining)));
      } else {
        double sum = 0.0;
        while (count < remaining) {
          const double w = st.weights[frame.nextUnit_ + count];
          if ((sum + w) * st.msPerWeight > room || sum + w > most) break;
          sum += w;
          ++count;
        }
      }
      if (count == 0) {
        if (!ranges.empty()) break;
        count = 1;  // one unit over the slice: it cannot be cut finer
      }
    } else {
      // Not measured yet: alone in its part (a pass of unknown cost, or a first range small
      // enough to measure: a kFirstRangeShare of the step's weight).
      if (!ranges.empty()) break;
      if (st.weights.empty()) {
        count = std::min(remaining, std::max(1u, st.units / kFirstRangeShare));
      } else {
        const double share = st.weightOf(frame.nextUnit_, remaining) / kFirstRangeShare;
        double sum = 0.0;
        while (count < remaining && (count == 0 || sum < share)) {
          sum += st.weights[frame.nextUnit_ + count];
          ++count;
        }
      }
    }
    st.record(cmd, frame.nextUnit_, count);
    const double weight = st.weightOf(frame.nextUnit_, count);
    ranges.push_back({&st, weight, st.msPerWeight * weight});
    plannedMs += st.msPerWeight * weight;
    st.lastRange = count;
    st.lastRangeWeight = weight;
    frame.nextUnit_ += count;
    // Measured alone; and a step continues in the next part (its next range sized from this one).
    if (st.msPerWeight <= 0.0 || frame.nextUnit_ < st.units) end = true;
    if (frame.nextUnit_ >= st.units) {
      // After the lists are built the host reads their counters before anything shades.
      if (st.listsBuilt) end = true;
      ++frame.step_;
      frame.nextUnit_ = 0;
    }
  }
  split.timer->end(cmd);
  gpu::submitAndWait(context, split.recorder);
  const double ms = Milliseconds(std::chrono::steady_clock::now() - partStart).count();
  frame.elapsedMs_ += ms;
  ++frame.submissions_;
  addPasses(frame.passes_, split.timer->results());

  // What each range cost: the part's time shared by the ranges' estimates (those not measured
  // yet share what the others did not take). An estimate rises to a costlier measurement at
  // once and falls by half a part at most, or a tenth where units differ (tiles of sky and of
  // long lists: a range sized from the cheapest ones would hold the queue for many slices).
  double known = 0.0;
  size_t unknown = 0;
  for (const Range& r : ranges) {
    if (r.plannedMs > 0.0) {
      known += r.plannedMs;
    } else {
      ++unknown;
    }
  }
  const double scale = known > 0.0 && unknown == 0 ? ms / known : 1.0;
  const double leftover = unknown > 0 ? std::max(ms - known, 0.0) / double(unknown) : 0.0;
  for (const Range& r : ranges) {
    const double weight = std::max(r.weight, 1e-6);
    const double measured =
        r.plannedMs > 0.0 ? r.step->msPerWeight * scale : std::max(leftover, 0.001) / weight;
    r.step->msPerWeight = r.step->msPerWeight <= 0.0
                              ? measured
                              : std::max(measured, (r.step->unitsAlike ? kEstimateDecayAlike
                                                                       : kEstimateDecayUnlike) *
                                                       r.step->msPerWeight);
    r.step->measuredWell = r.step->measuredWell || measured * weight >= kWellMeasured * sliceMs;
  }

  // The lists are complete: when they overflowed and may grow, the lighting starts again with
  // larger ones (a frame with lights missing is never the answer while memory allows).
  const bool listsDone = !ranges.empty() && ranges.back().step->listsBuilt &&
                         frame.nextUnit_ == 0;
  if (listsDone) {
    LightingTechnique& technique = splitTechnique(frame.settings_.technique);
    if (const gpu::Buffer* counters = technique.counters()) {
      CullingReport report;
      technique.report(report, counters->mapped);
      if (technique.growLists(report)) {
        SceneBuffers& scene = this->scene(frame.scene_);
        const VkExtent2D extent = split.targets->extent;
        try {
          technique.prepare(extent, scene.lightCount);
        } catch (const gpu::VulkanError&) {
          technique.growthFailed();  // out of memory for them: the lists of before, once more
          technique.prepare(extent, scene.lightCount);
        }
        // The lists' capacity is in the uniforms.
        const std::optional<SunShadowFit> sun = sunShadowFor(scene, frame.settings_);
        writeUniforms(split, frame.settings_, scene, technique, sun ? &*sun : nullptr,
                      split.lightShadows);
        frame.listsGrew_ = true;
        frame.step_ = frame.firstLightingStep_;
        frame.nextUnit_ = 0;
        for (size_t i = frame.firstLightingStep_; i < frame.steps_.size(); ++i) {
          frame.steps_[i].weighed = false;
          frame.steps_[i].weights.clear();
          if (frame.steps_[i].lightingStep >= 0) frame.steps_[i].units = frame.steps_[i].declaredUnits;
        }
      }
    }
  }
}

std::optional<Frame> Renderer::continueSplit(SplitFrame& frame) {
  State& s = *state_;
  const FrameSettings& settings = frame.settings_;
  SceneBuffers& scene = s.scene(frame.scene_);
  LightingTechnique& technique = s.splitTechnique(settings.technique);
  SceneEnvironment* environment = s.environmentFor(frame.scene_, settings);
  if (s.frameBudgetMs > 0.0) {
    // Over the budget, or projected past it by its parts measured so far once it has taken a
    // share of it (the first parts' estimates are rough, and a frame is not refused on them).
    const double projected = frame.projectedMilliseconds();
    const bool projectedOver = frame.elapsedMs_ >= kProjectAfterShare * s.frameBudgetMs &&
                               projected > s.frameBudgetMs;
    if (frame.elapsedMs_ > s.frameBudgetMs || projectedOver) {
      char detail[256];
      std::snprintf(detail, sizeof detail,
                    "the frame would take the renderer about %.1f s (%.1f s of it taken in %u "
                    "parts), over the budget of %.1f s a frame",
                    projected / 1000.0, frame.elapsedMs_ / 1000.0, frame.submissions_,
                    s.frameBudgetMs / 1000.0);
      throw FrameBudgetError(detail, s.frameBudgetMs, frame.elapsedMs_, projected);
    }
  }
  s.runSplitPart(frame);
  while (frame.step_ < frame.steps_.size() &&
         frame.nextUnit_ >= frame.steps_[frame.step_].units) {
    ++frame.step_;
    frame.nextUnit_ = 0;
  }
  if (frame.step_ < frame.steps_.size()) return std::nullopt;
  Frame result = s.readFrame(s.split, State::metaOf(scene, environment, settings), settings,
                             technique);
  result.passes = frame.passes_;
  result.submissions = frame.submissions_;
  result.culling.listsGrew = frame.listsGrew_;
  s.costs[frame.scene_] = {settings.technique, pixelsOf(settings), scene.lightCount,
                           frame.elapsedMs_};
  return result;
}

}  // namespace myriad::render
