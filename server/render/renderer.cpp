#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/renderer_state.h"
#include "render/techniques/registry.h"

namespace myriad::render {

namespace {

// The frame uniforms are one small buffer; a default 64 MiB block would be almost all waste.
constexpr VkDeviceSize kUniformBlockSize = 64ull << 10;

}  // namespace

Renderer::State::State(gpu::Context& c, const Tuning& asked)
    : context(c), tuning(resolveTuning(asked, c.info)), pipelines(c),
      techniques(createTechniques({c, pipelines, tuning})),
      computeGBuffer(c, pipelines.sceneSetLayout, kMaxFramesInFlight + 1),
      skinning(c), motion(c, pipelines.sceneSetLayout, kMaxFramesInFlight + 1),
      stochastic(c, pipelines, tuning),
      uniformArena(c, kUniformBlockSize) {
  // The passes after the lighting, registered ones at their places (render/frame_pass.h).
  const std::vector<const FramePass*>& registered = registeredFramePasses();
  auto addRegistered = [&](FramePassPlace place) {
    for (const FramePass* pass : registered) {
      if (pass->place != place) continue;
      afterSteps.push_back({AfterStep::Registered, pass,
                            gpu::createComputePipeline(c.device, pipelines.layout, pass->shader)});
    }
  };
  afterSteps.push_back({AfterStep::Forward});
  addRegistered(FramePassPlace::Hdr);
  afterSteps.push_back({AfterStep::Final});
  afterSteps.push_back({AfterStep::Antialias});
  addRegistered(FramePassPlace::Output);
  afterSteps.push_back({AfterStep::Readback});
  const auto timedPasses = kMaxTimedPasses + static_cast<uint32_t>(registered.size());
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) slots.push_back(std::make_unique<FrameSlot>());
  for (FrameSlot* slot : allSlots()) {
    slot->shadows = std::make_unique<ShadowMaps>(c);
    slot->timer = std::make_unique<gpu::PassTimer>(c, timedPasses);
  }
  for (const auto& technique : techniques) {
    splitTechniques.push_back(technique->splitInstance({c, pipelines, tuning}));
  }
}

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
  s.temporal = std::make_unique<TemporalHistories>(context, s.sampler, s.linearSampler,
                                                   [&s] { s.quiesce(); });

  // Sets 0 (scene) and 1 (targets, twice: rawTargetSet) of every frame slot; each technique
  // allocates its own set 2.
  const auto n = static_cast<uint32_t>(slots.size());
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, n * 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, n * 12},  // + the edge pixels, the YCbCr planes, the cluster marks (set 1, twice)
                                  // + the shadow maps, the LDR target, the layers target
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, n * 24},
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
  s.temporal.reset();
  for (const State::AfterStep& step : s.afterSteps) {
    if (step.pipeline) vkDestroyPipeline(s.context.device, step.pipeline, nullptr);
  }
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

void Renderer::setGpuTimestamps(GpuTimestamps mode) {
  for (State::FrameSlot* slot : state_->allSlots()) {
    slot->timer->setFrameOnly(mode == GpuTimestamps::Frame);
    slot->timer->setOff(mode == GpuTimestamps::None);
  }
}

void Renderer::limitListMemory(uint64_t bytes, uint64_t startBytes) {
  state_->quiesce();
  for (const auto& technique : state_->techniques) technique->limitListMemory(bytes, startBytes);
  for (const auto& technique : state_->splitTechniques) {
    if (technique) technique->limitListMemory(bytes, startBytes);
  }
}

uint32_t Renderer::maxDimension() const { return state_->context.info.maxImageDimension2D; }

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

std::optional<SunShadowFit> Renderer::State::sunShadowFor(const SceneBuffers& scene,
                                                          const FrameSettings& settings) {
  if (!settings.shadows.sun || settings.sun.intensity <= 0.0f || scene.draws.empty()) {
    return std::nullopt;
  }
  if (tracesLocalShadows(settings)) return std::nullopt;  // traced instead (stochastic_shadows.h)
  // The camera's, unjittered (TAA's sub-frames share their maps).
  return fitSunCascades(scene.bounds, settings.sun.direction, settings.shadows.mapSize,
                        settings.shadows.cascades, settings.camera,
                        float(settings.width) / float(settings.height),
                        settings.shadows.snapCascades);
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

uint32_t Renderer::beginWhole(SceneId id, const FrameSettings& asked) {
  State& s = *state_;
  SceneBuffers& scene = s.scene(id);
  checkSize(asked, maxDimension());
  checkLabels(asked);
  s.technique(asked.technique);  // throws for an unknown technique
  SceneEnvironment* environment = s.environmentFor(id, asked);
  const uint32_t index = s.pickSlot(asked);
  if (index == s.framesInFlight) throw std::logic_error("every frame slot is in flight");
  State::FrameSlot& slot = *s.slots[index];
  // A stream's taa frame: jittered, its history's next frame (render/temporal.h).
  const FrameSettings settings = s.temporal->plan(asked, slot.temporal);
  slot.resolve.reset();  // a whole frame of its own (beginFrame sets it for a frame's last part)
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
Frame Renderer::finishWhole(uint32_t index) {
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

}  // namespace myriad::render
