#include "render/renderer.h"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/cluster_grid.h"
#include "render/compute_passes.h"
#include "render/environment.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "render/shadows.h"
#include "render/techniques/registry.h"
#include "render/techniques/technique.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// environment (when rebuilt), animate, shadow, gbuffer, the technique's (sun + lights, or lighting),
// markers, tonemap, overlay, readback: room for a technique of four passes.
constexpr uint32_t kMaxTimedPasses = 12;

// The light-count view's hottest colour when the request leaves it to us.
constexpr uint32_t kDefaultHeatMapMax = 64;

// The frame uniforms are one small buffer; a default 64 MiB block would be almost all waste.
constexpr VkDeviceSize kUniformBlockSize = 64ull << 10;

}  // namespace

struct Renderer::State {
  explicit State(gpu::Context& c)
      : context(c), pipelines(c), techniques(createTechniques({c, pipelines})),
        uniformArena(c, kUniformBlockSize), timer(c, kMaxTimedPasses), shadows(c) {}

  gpu::Context& context;
  Pipelines pipelines;
  // Index = Technique (techniques/registry.h); destroyed before the pipeline layout they use.
  std::vector<std::unique_ptr<LightingTechnique>> techniques;
  gpu::Arena uniformArena;
  gpu::Buffer uniforms;
  gpu::CommandRecorder recorder;
  gpu::PassTimer timer;
  ShadowMaps shadows;  // the sun's map, shared by every scene (rendered each frame it is on)
  VkSampler sampler = VK_NULL_HANDLE;
  VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
  // One set per kind, rewritten for whichever scene the frame draws: frames run one at a time.
  VkDescriptorSet sceneSet = VK_NULL_HANDLE;
  VkDescriptorSet targetSet = VK_NULL_HANDLE;  // set 2 (light culling) is each technique's own
  std::unordered_map<SceneId, std::unique_ptr<SceneBuffers>> scenes;
  // The BRDF table and the passes that build environments (created after the recorder).
  std::unique_ptr<EnvironmentPasses> environmentPasses;
  // A scene's environment maps, from its first frame with the environment on or its first .hdr;
  // kept when the scene is replaced (a new model keeps the session's environment).
  std::unordered_map<SceneId, std::unique_ptr<SceneEnvironment>> environments;
  SceneId nextSceneId = 1;
  // Shared by every scene: sized for the frame being drawn, rebuilt when that changes.
  std::unique_ptr<FrameTargets> targets;

  SceneBuffers& scene(SceneId id);
  const SceneBuffers& scene(SceneId id) const;
  LightingTechnique& technique(Technique t);
  void writeSceneSet(const SceneBuffers& scene, const gpu::Buffer& environment);
  SceneEnvironment& environment(SceneId id);
  void writeTargetSet();
  void writeUniforms(const FrameSettings& settings, const SceneBuffers& scene,
                     const LightingTechnique& technique, const SunShadowFit* sunShadow);
  void ensureTargets(VkExtent2D extent, bool raw);
  Frame renderOnce(SceneBuffers& scene, SceneEnvironment* environment,
                   const FrameSettings& settings);
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
void Renderer::State::writeSceneSet(const SceneBuffers& scene, const gpu::Buffer& environment) {
  const VkDescriptorImageInfo sunShadowMap = shadows.sunDescriptor();
  VkDescriptorBufferInfo buffers[7] = {
      {uniforms.buffer, 0, sizeof(FrameUniforms)},
      {scene.lights.buffer, 0, VK_WHOLE_SIZE},
      {scene.instances.buffer, 0, VK_WHOLE_SIZE},
      {scene.materials.buffer, 0, VK_WHOLE_SIZE},
      {scene.lightOrigins.buffer, 0, VK_WHOLE_SIZE},
      {environment.buffer, 0, VK_WHOLE_SIZE},
      {environmentPasses->brdfLut().buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[8];
  for (uint32_t i = 0; i < 7; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = sceneSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        i == MYRIAD_BINDING_FRAME ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  writes[7] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  writes[7].dstSet = sceneSet;
  writes[7].dstBinding = MYRIAD_BINDING_SUN_SHADOW_MAP;
  writes[7].descriptorCount = 1;
  writes[7].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[7].pImageInfo = &sunShadowMap;
  vkUpdateDescriptorSets(context.device, 8, writes, 0, nullptr);
}

void Renderer::State::writeTargetSet() {
  // Bindings 0-6 and 9 are sampled (READ_ONLY_OPTIMAL); 7-8 are the same HDR and light-count
  // images as storage images (GENERAL), written by compute lighting; 10 the markers' keys
  // (storage, GENERAL).
  const gpu::Image* images[11] = {&targets->depth,      &targets->normal, &targets->baseColor,
                                  &targets->material,   &targets->uv,     &targets->hdr,
                                  &targets->lightCount, &targets->hdr,    &targets->lightCount,
                                  &targets->emissive,   &targets->markerKeys};
  VkDescriptorImageInfo infos[11];
  VkWriteDescriptorSet writes[11];
  for (uint32_t i = 0; i < 11; ++i) {
    bool storage = i == MYRIAD_BINDING_HDR_STORAGE || i == MYRIAD_BINDING_LIGHT_COUNT_STORAGE ||
                   i == MYRIAD_BINDING_MARKER_KEYS;
    infos[i] = {storage ? VK_NULL_HANDLE : sampler, images[i]->view,
                storage ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = targetSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        storage ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &infos[i];
  }
  vkUpdateDescriptorSets(context.device, 11, writes, 0, nullptr);
}

// Targets follow the output size and are rebuilt only when it changes (every frame is waited
// for, so nothing is in flight here).
void Renderer::State::ensureTargets(VkExtent2D extent, bool raw) {
  if (!targets || targets->extent.width != extent.width ||
      targets->extent.height != extent.height || targets->raw != raw) {
    targets.reset();
    targets = std::make_unique<FrameTargets>(context, extent, raw);
    writeTargetSet();
  }
}

void Renderer::State::writeUniforms(const FrameSettings& s, const SceneBuffers& scene,
                                    const LightingTechnique& technique,
                                    const SunShadowFit* sunShadow) {
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
  // The cluster grid: the clustered technique's, and the clusters view's whatever the technique.
  const ClusterGrid g = clusterGrid({s.width, s.height});
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
  if (sunShadow) {
    u.sunShadowMatrix = sunShadow->mapFromWorld;
    // Offset: a texel along the normal (more at grazing angles, frame.glsl); bias: a texel of
    // depth (the map's depth range is as deep as it is wide), scaled by the slope there.
    u.sunShadow = glm::vec4(1.0f, sunShadow->texelWorld, 1.0f / float(s.shadows.mapSize),
                            1.0f / float(s.shadows.mapSize));
  }
  technique.writeUniforms(u);
  std::memcpy(uniforms.mapped, &u, sizeof(u));
}

Renderer::Renderer(gpu::Context& context) : state_(std::make_unique<State>(context)) {
  State& s = *state_;
  VkDevice device = context.device;
  s.uniforms = s.uniformArena.createBuffer(sizeof(FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                           gpu::MemoryUse::Upload);
  s.recorder = gpu::createCommandRecorder(context);
  s.environmentPasses = std::make_unique<EnvironmentPasses>(context, s.recorder);

  VkSamplerCreateInfo samplerInfo{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_NEAREST;
  samplerInfo.addressModeU = samplerInfo.addressModeV = samplerInfo.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VK_CHECK(vkCreateSampler(device, &samplerInfo, nullptr, &s.sampler));

  // Sets 0 (scene) and 1 (targets); each technique allocates its own set 2.
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 6},
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 9},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 3}};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 4;
  poolInfo.pPoolSizes = sizes;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &s.descriptorPool));
  VkDescriptorSetLayout layouts[] = {s.pipelines.sceneSetLayout, s.pipelines.targetSetLayout};
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = s.descriptorPool;
  alloc.descriptorSetCount = 2;
  alloc.pSetLayouts = layouts;
  VkDescriptorSet sets[2];
  VK_CHECK(vkAllocateDescriptorSets(device, &alloc, sets));
  s.sceneSet = sets[0];
  s.targetSet = sets[1];
}

Renderer::~Renderer() {
  State& s = *state_;
  vkDeviceWaitIdle(s.context.device);
  s.targets.reset();
  s.techniques.clear();
  s.scenes.clear();
  s.environments.clear();
  s.environmentPasses.reset();
  vkDestroyDescriptorPool(s.context.device, s.descriptorPool, nullptr);
  vkDestroySampler(s.context.device, s.sampler, nullptr);
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
  // Build the new buffers before dropping the old, so a failure leaves the old scene in place.
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene,
                                                s.pipelines.materialSetLayout);
  s.scenes[id] = std::move(buffers);
}

void Renderer::destroyScene(SceneId id) {
  State& s = *state_;
  s.scene(id);  // throws for an unknown id
  s.scenes.erase(id);
  s.environments.erase(id);
}

void Renderer::setEnvironmentImage(SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) {
  state_->environment(id).setImage(std::move(image));
}

uint64_t Renderer::environmentRebuilds(SceneId id) const {
  state_->scene(id);
  auto it = state_->environments.find(id);
  return it == state_->environments.end() ? 0 : it->second->rebuilds;
}

void Renderer::updateLights(SceneId id, const LightUpdate& update) {
  state_->scene(id).updateLights(state_->recorder, update);
}

void Renderer::updateMaterials(SceneId id, const std::vector<MaterialWrite>& writes) {
  state_->scene(id).updateMaterials(state_->recorder, writes);
}

bool Renderer::hasScene(SceneId id) const { return state_->scenes.contains(id); }

uint32_t Renderer::lightCount(SceneId id) const { return state_->scene(id).lightCount; }

uint64_t Renderer::sceneBytes(SceneId id) const {
  auto it = state_->environments.find(id);
  return state_->scene(id).bytes() + (it == state_->environments.end() ? 0 : it->second->bytes());
}

void Renderer::releaseFrameMemory() {
  // Every frame is waited for, so nothing in flight uses the targets; the target descriptor set
  // points at freed views until ensureTargets() makes new ones and writes it again.
  state_->targets.reset();
  state_->shadows.release();
}

uint64_t Renderer::gpuMemoryBytes() const {
  const State& s = *state_;
  uint64_t total = s.uniformArena.bytesAllocated();
  for (const auto& [id, scene] : s.scenes) total += scene->bytes();
  for (const auto& [id, env] : s.environments) total += env->bytes();
  total += s.environmentPasses->gpuMemoryBytes();
  if (s.targets) total += s.targets->arena.bytesAllocated();
  total += s.shadows.gpuMemoryBytes();
  for (const auto& technique : s.techniques) total += technique->gpuMemoryBytes();
  return total;
}

void Renderer::limitListMemory(uint64_t bytes, uint64_t startBytes) {
  for (const auto& technique : state_->techniques) technique->limitListMemory(bytes, startBytes);
}

uint32_t Renderer::maxDimension() const { return state_->context.info.maxImageDimension2D; }

// Renders, and when the technique's lists overflowed but may still grow, grows them and renders
// the frame once more: a frame with lights missing is never the answer while memory allows.
Frame Renderer::render(SceneId id, const FrameSettings& settings) {
  State& s = *state_;
  SceneBuffers& scene = s.scene(id);
  if (settings.width == 0 || settings.height == 0 || settings.width > maxDimension() ||
      settings.height > maxDimension()) {
    throw std::invalid_argument("frame size " + std::to_string(settings.width) + "x" +
                                std::to_string(settings.height) + " is outside 1.." +
                                std::to_string(maxDimension()));
  }
  LightingTechnique& technique = s.technique(settings.technique);
  SceneEnvironment* environment = nullptr;
  if (settings.environment.mode != EnvironmentMode::None) {
    environment = &s.environment(id);
    EnvironmentPasses::inputsFor(settings, *environment);  // throws for hdr without an image
  }
  Frame frame = s.renderOnce(scene, environment, settings);
  if (technique.growLists(frame.culling)) {
    try {
      Frame regrown = s.renderOnce(scene, environment, settings);
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

// The frame, top to bottom. Every request (any view, any size, any technique) takes this path.
Frame Renderer::State::renderOnce(SceneBuffers& scene, SceneEnvironment* environment,
                                  const FrameSettings& settings) {
  State& s = *this;
  LightingTechnique& technique = s.technique(settings.technique);
  VkExtent2D extent{settings.width, settings.height};
  s.ensureTargets(extent, settings.raw);
  technique.prepare(extent, scene.lightCount);
  // The sun's shadow map: fitted to this scene and sun, rendered this frame when on.
  const bool sunShadows = settings.shadows.sun && settings.sun.intensity > 0.0f &&
                          !scene.draws.empty();
  SunShadowFit sunShadow;
  if (sunShadows) {
    s.shadows.ensureSun(settings.shadows.mapSize);
    sunShadow = fitSunShadow(scene.bounds, settings.sun.direction, settings.shadows.mapSize);
  } else {
    s.shadows.ensureSunPlaceholder();
  }
  s.writeUniforms(settings, scene, technique, sunShadows ? &sunShadow : nullptr);
  s.writeSceneSet(scene, environment ? environment->lighting : environmentPasses->brdfLut());
  const FrameTargets& t = *s.targets;
  const Pipelines& p = s.pipelines;

  VkCommandBuffer cmd = gpu::beginCommands(s.context, s.recorder);
  VkDescriptorSet sets[] = {s.sceneSet, s.targetSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 2, sets, 0, nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  s.timer.reset(cmd);

  if (environment) {
    const SceneEnvironment::Inputs inputs = EnvironmentPasses::inputsFor(settings, *environment);
    if (environment->built != inputs) {
      s.timer.beginPass(cmd, "environment");
      environmentPasses->record(cmd, *environment, inputs);
      // The environment passes bound their own layout's set 0; the frame's sets go back.
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
    }
  }

  if (settings.animate) {
    s.timer.beginPass(cmd, "animate");
    recordAnimateLights(cmd, p, scene);
    scene.lightsMoved = true;
  } else if (scene.lightsMoved) {
    recordRestoreLights(cmd, scene);
    scene.lightsMoved = false;
  }
  if (sunShadows) {
    s.timer.beginPass(cmd, "shadow");
    s.shadows.recordSun(cmd, p, scene, sunShadow.viewProjection);
  } else {
    s.shadows.recordSunUnused(cmd);
  }
  s.timer.beginPass(cmd, "gbuffer");
  recordGBufferPass(cmd, p, t, scene);
  // Lighting leaves HDR and light counts as attachments (raster) or storage images (compute).
  const VkImageLayout lightingLayout = technique.record({cmd, s.timer, t, scene});
  VkImageLayout hdrLayout = lightingLayout;
  if (settings.markers) {
    s.timer.beginPass(cmd, "markers");
    recordMarkerPass(cmd, p, t, scene, hdrLayout);
    hdrLayout = VK_IMAGE_LAYOUT_GENERAL;
  }
  s.timer.beginPass(cmd, "tonemap");
  recordTonemapPass(cmd, p, t, hdrLayout, lightingLayout);
  if (settings.target == Target::LightVolumes && !settings.raw) {
    s.timer.beginPass(cmd, "overlay");
    recordLightVolumeOverlayPass(cmd, p, t, scene);
  }
  s.timer.beginPass(cmd, "readback");
  recordReadback(cmd, t);
  s.timer.end(cmd);
  gpu::submitAndWait(s.context, s.recorder);

  Frame frame;
  frame.width = extent.width;
  frame.height = extent.height;
  if (settings.raw) {
    frame.data.resize(size_t(extent.width) * extent.height * 4);
    std::memcpy(frame.data.data(), t.readback.mapped, frame.data.size() * sizeof(float));
  } else {
    frame.rgba.resize(size_t(extent.width) * extent.height * 4);
    std::memcpy(frame.rgba.data(), t.readback.mapped, frame.rgba.size());
  }
  for (auto& [name, ms] : s.timer.results()) frame.passes.push_back({name, ms});
  frame.technique = settings.technique;
  frame.lightCount = scene.lightCount;
  frame.sceneBytes = scene.bytes() + (environment ? environment->bytes() : 0);
  frame.culling.lightBytes = scene.lights.size + scene.lightOrigins.size;
  technique.report(frame.culling);
  return frame;
}

}  // namespace myriad::render
