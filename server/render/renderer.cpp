#include "render/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/compute_passes.h"
#include "render/frame_targets.h"
#include "render/light_grid.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// animate, gbuffer, sun, lights/lighting, markers, tonemap, overlay, readback.
constexpr uint32_t kMaxTimedPasses = 10;

// The light-count view's hottest colour when the request leaves it to us.
constexpr uint32_t kDefaultHeatMapMax = 64;

// The frame uniforms are one small buffer; a default 64 MiB block would be almost all waste.
constexpr VkDeviceSize kUniformBlockSize = 64ull << 10;

// Overflowing cluster lists grow to this much more than the frame needed, so a view that moves a
// little does not overflow again on the next frame.
constexpr double kListGrowth = 1.25;

}  // namespace

struct Renderer::State {
  explicit State(gpu::Context& c)
      : context(c), pipelines(c), uniformArena(c, kUniformBlockSize), timer(c, kMaxTimedPasses) {}

  gpu::Context& context;
  Pipelines pipelines;
  gpu::Arena uniformArena;
  gpu::Buffer uniforms;
  gpu::CommandRecorder recorder;
  gpu::PassTimer timer;
  VkSampler sampler = VK_NULL_HANDLE;
  VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
  // One set per kind, rewritten for whichever scene the frame draws: frames run one at a time.
  VkDescriptorSet sceneSet = VK_NULL_HANDLE;
  VkDescriptorSet targetSet = VK_NULL_HANDLE;
  VkDescriptorSet cullingSet = VK_NULL_HANDLE;
  std::unordered_map<SceneId, std::unique_ptr<SceneBuffers>> scenes;
  SceneId nextSceneId = 1;
  // Shared by every scene: sized for the frame being drawn, rebuilt when that changes.
  std::unique_ptr<FrameTargets> targets;
  std::unique_ptr<LightGrid> grid;
  uint64_t listLimitBytes = 0;     // limitListMemory(); 0 = the device's limit
  uint32_t listStartCapacity = 0;  // limitListMemory(); 0 = lightGridSize()'s
  uint32_t grownListCapacity = 0;  // what overflowing lists grew to (kept for later frames)
  uint32_t failedListCapacity = UINT32_MAX;  // lists this large could not be allocated

  SceneBuffers& scene(SceneId id);
  const SceneBuffers& scene(SceneId id) const;
  uint64_t maxListBytes() const;
  void writeSceneSet(const SceneBuffers& scene);
  void writeTargetSet();
  void writeCullingSet();
  void writeUniforms(const FrameSettings& settings, const SceneBuffers& scene);
  void ensureTargets(VkExtent2D extent, bool raw, uint32_t lightCount);
  Frame renderOnce(SceneBuffers& scene, const FrameSettings& settings);
};

SceneBuffers& Renderer::State::scene(SceneId id) {
  auto it = scenes.find(id);
  if (it == scenes.end()) throw std::invalid_argument("no scene " + std::to_string(id) + " on the GPU");
  return *it->second;
}

const SceneBuffers& Renderer::State::scene(SceneId id) const {
  return const_cast<State*>(this)->scene(id);
}

uint64_t Renderer::State::maxListBytes() const {
  uint64_t device = context.info.maxStorageBufferRange;
  return listLimitBytes > 0 ? std::min(listLimitBytes, device) : device;
}

void Renderer::State::writeSceneSet(const SceneBuffers& scene) {
  VkDescriptorBufferInfo buffers[5] = {
      {uniforms.buffer, 0, sizeof(FrameUniforms)},
      {scene.lights.buffer, 0, VK_WHOLE_SIZE},
      {scene.instances.buffer, 0, VK_WHOLE_SIZE},
      {scene.materials.buffer, 0, VK_WHOLE_SIZE},
      {scene.lightOrigins.buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[5];
  for (uint32_t i = 0; i < 5; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = sceneSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        i == MYRIAD_BINDING_FRAME ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  vkUpdateDescriptorSets(context.device, 5, writes, 0, nullptr);
}

void Renderer::State::writeTargetSet() {
  // Bindings 0-6 are sampled (READ_ONLY_OPTIMAL); 7-8 are the same HDR and light-count images
  // as storage images (GENERAL), written by compute lighting.
  const gpu::Image* images[9] = {&targets->depth, &targets->normal,     &targets->baseColor,
                                 &targets->material, &targets->uv,      &targets->hdr,
                                 &targets->lightCount, &targets->hdr,   &targets->lightCount};
  VkDescriptorImageInfo infos[9];
  VkWriteDescriptorSet writes[9];
  for (uint32_t i = 0; i < 9; ++i) {
    bool storage = i >= MYRIAD_BINDING_HDR_STORAGE;
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
  vkUpdateDescriptorSets(context.device, 9, writes, 0, nullptr);
}

void Renderer::State::writeCullingSet() {
  VkDescriptorBufferInfo buffers[4] = {
      {grid->ranges.buffer, 0, VK_WHOLE_SIZE},
      {grid->lists.buffer, 0, VK_WHOLE_SIZE},
      {grid->stats.buffer, 0, VK_WHOLE_SIZE},
      {grid->cursors.buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[4];
  for (uint32_t i = 0; i < 4; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = cullingSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  vkUpdateDescriptorSets(context.device, 4, writes, 0, nullptr);
}

// Targets follow the output size; the light grid follows the size, the light count and what the
// lists grew to. Both are rebuilt only when they change (every frame is waited for, so nothing is
// in flight here).
void Renderer::State::ensureTargets(VkExtent2D extent, bool raw, uint32_t lightCount) {
  if (!targets || targets->extent.width != extent.width ||
      targets->extent.height != extent.height || targets->raw != raw) {
    targets.reset();
    targets = std::make_unique<FrameTargets>(context, extent, raw);
    writeTargetSet();
  }
  const uint64_t mostReferences = maxListBytes() / sizeof(uint32_t);
  LightGridSize size = lightGridSize(extent, lightCount, maxListBytes());
  if (listStartCapacity > 0) size.listCapacity = listStartCapacity;
  size.listCapacity = static_cast<uint32_t>(
      std::min<uint64_t>(std::max(size.listCapacity, grownListCapacity), mostReferences));
  // Sessions' scenes take turns: a grid whose lists hold what this frame wants, without more
  // than twice the waste, stays, so frames of a 1,000-light and a 100,000-light scene in turn do
  // not reallocate the lists every frame.
  const bool keep = grid && grid->size.clustersX == size.clustersX &&
                    grid->size.clustersY == size.clustersY && grid->size.slices == size.slices &&
                    grid->size.listCapacity >= size.listCapacity &&
                    grid->size.listCapacity <= 2 * uint64_t(size.listCapacity) &&
                    grid->size.listCapacity <= mostReferences;
  if (!keep) {
    grid.reset();
    grid = std::make_unique<LightGrid>(context, size);
    writeCullingSet();
  }
}

void Renderer::State::writeUniforms(const FrameSettings& s, const SceneBuffers& scene) {
  float aspect = float(s.width) / float(s.height);
  glm::mat4 view = scene::viewMatrix(s.camera);
  glm::mat4 projection = scene::projectionMatrix(s.camera, aspect);
  const scene::Bounds& bounds = scene.bounds;
  float diagonal = bounds.empty() ? 1.0f : glm::length(bounds.size());

  FrameUniforms u{};
  u.view = view;
  u.projection = projection;
  u.viewProjection = projection * view;
  u.inverseViewProjection = glm::inverse(u.viewProjection);
  u.cameraPosition = glm::vec4(s.camera.eye, 1.0f);
  u.sunDirection = glm::vec4(-glm::normalize(s.sun.direction), s.sun.intensity);
  u.sunColor = glm::vec4(s.sun.color, 0.0f);
  u.ambient = glm::vec4(s.ambient, 0.0f);
  u.background = glm::vec4(s.background, 0.0f);
  u.viewport = glm::vec4(s.width, s.height, 1.0f / s.width, 1.0f / s.height);
  // Markers are a fixed fraction of the scene's size: visible in a wide shot, never huge.
  u.camera = glm::vec4(s.exposure, s.camera.nearPlane, s.camera.farPlane, diagonal * 0.0025f);
  u.boundsMin = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.min, 0.0f);
  u.boundsMax = glm::vec4(bounds.empty() ? glm::vec3(1.0f) : bounds.max, 0.0f);
  const LightGridSize& g = grid->size;
  u.flags = glm::uvec4(static_cast<uint32_t>(s.target), scene.lightCount, s.raw ? 1 : 0,
                       g.listCapacity);
  u.grid = glm::uvec4(g.clustersX, g.clustersY, g.slices, static_cast<uint32_t>(s.technique));
  float slicesPerLog = float(g.slices) / std::log(s.camera.farPlane / s.camera.nearPlane);
  u.slicing = glm::vec4(slicesPerLog, std::log(s.camera.nearPlane) * slicesPerLog,
                        float(s.heatMapMax > 0 ? s.heatMapMax : kDefaultHeatMapMax), float(s.time));
  std::memcpy(uniforms.mapped, &u, sizeof(u));
}

Renderer::Renderer(gpu::Context& context) : state_(std::make_unique<State>(context)) {
  State& s = *state_;
  VkDevice device = context.device;
  s.uniforms = s.uniformArena.createBuffer(sizeof(FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                           gpu::MemoryUse::Upload);
  s.recorder = gpu::createCommandRecorder(context);

  VkSamplerCreateInfo samplerInfo{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  samplerInfo.magFilter = samplerInfo.minFilter = VK_FILTER_NEAREST;
  samplerInfo.addressModeU = samplerInfo.addressModeV = samplerInfo.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VK_CHECK(vkCreateSampler(device, &samplerInfo, nullptr, &s.sampler));

  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 8},
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 7},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2}};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 3;
  poolInfo.poolSizeCount = 4;
  poolInfo.pPoolSizes = sizes;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &s.descriptorPool));
  VkDescriptorSetLayout layouts[] = {s.pipelines.sceneSetLayout, s.pipelines.targetSetLayout,
                                     s.pipelines.cullingSetLayout};
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = s.descriptorPool;
  alloc.descriptorSetCount = 3;
  alloc.pSetLayouts = layouts;
  VkDescriptorSet sets[3];
  VK_CHECK(vkAllocateDescriptorSets(device, &alloc, sets));
  s.sceneSet = sets[0];
  s.targetSet = sets[1];
  s.cullingSet = sets[2];
}

Renderer::~Renderer() {
  State& s = *state_;
  vkDeviceWaitIdle(s.context.device);
  s.targets.reset();
  s.grid.reset();
  s.scenes.clear();
  vkDestroyDescriptorPool(s.context.device, s.descriptorPool, nullptr);
  vkDestroySampler(s.context.device, s.sampler, nullptr);
  gpu::destroyCommandRecorder(s.context, s.recorder);
}

SceneId Renderer::createScene(const scene::Scene& scene) {
  State& s = *state_;
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene);
  SceneId id = s.nextSceneId++;
  s.scenes.emplace(id, std::move(buffers));
  return id;
}

void Renderer::replaceScene(SceneId id, const scene::Scene& scene) {
  State& s = *state_;
  s.scene(id);  // throws for an unknown id
  // Build the new buffers before dropping the old, so a failure leaves the old scene in place.
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene);
  s.scenes[id] = std::move(buffers);
}

void Renderer::destroyScene(SceneId id) {
  State& s = *state_;
  s.scene(id);  // throws for an unknown id
  s.scenes.erase(id);
}

void Renderer::updateLights(SceneId id, const LightUpdate& update) {
  state_->scene(id).updateLights(state_->recorder, update);
}

void Renderer::updateMaterials(SceneId id, const std::vector<MaterialWrite>& writes) {
  state_->scene(id).updateMaterials(state_->recorder, writes);
}

bool Renderer::hasScene(SceneId id) const { return state_->scenes.contains(id); }

uint32_t Renderer::lightCount(SceneId id) const { return state_->scene(id).lightCount; }

uint64_t Renderer::sceneBytes(SceneId id) const { return state_->scene(id).bytes(); }

uint64_t Renderer::gpuMemoryBytes() const {
  const State& s = *state_;
  uint64_t total = s.uniformArena.bytesAllocated();
  for (const auto& [id, scene] : s.scenes) total += scene->bytes();
  if (s.targets) total += s.targets->arena.bytesAllocated();
  if (s.grid) total += s.grid->arena.bytesAllocated();
  return total;
}

void Renderer::limitListMemory(uint64_t bytes, uint64_t startBytes) {
  state_->listLimitBytes = bytes;
  state_->listStartCapacity = static_cast<uint32_t>(
      std::min<uint64_t>(startBytes / sizeof(uint32_t), UINT32_MAX));
  state_->grownListCapacity = 0;
  state_->failedListCapacity = UINT32_MAX;
}

uint32_t Renderer::maxDimension() const { return state_->context.info.maxImageDimension2D; }

// Renders, and when the clustered lists overflowed but may still grow, grows them and renders the
// frame once more: a frame with lights missing is never the answer while memory allows.
Frame Renderer::render(SceneId id, const FrameSettings& settings) {
  State& s = *state_;
  SceneBuffers& scene = s.scene(id);
  if (settings.width == 0 || settings.height == 0 || settings.width > maxDimension() ||
      settings.height > maxDimension()) {
    throw std::invalid_argument("frame size " + std::to_string(settings.width) + "x" +
                                std::to_string(settings.height) + " is outside 1.." +
                                std::to_string(maxDimension()));
  }
  Frame frame = s.renderOnce(scene, settings);
  const CullingReport& c = frame.culling;
  const uint64_t mostReferences = s.maxListBytes() / sizeof(uint32_t);
  if (settings.technique == Technique::Clustered && c.clusterLightsDropped > 0 &&
      c.listCapacity < mostReferences && c.listCapacity < s.failedListCapacity) {
    const uint64_t needed = uint64_t(c.listEntries) + c.clusterLightsDropped;
    const auto grown = static_cast<uint64_t>(std::ceil(double(needed) * kListGrowth));
    const uint32_t previous = s.grownListCapacity;
    s.grownListCapacity = static_cast<uint32_t>(
        std::min({grown, mostReferences, uint64_t(s.failedListCapacity) - 1}));
    try {
      Frame regrown = s.renderOnce(scene, settings);
      regrown.culling.listsGrew = true;
      return regrown;
    } catch (const gpu::VulkanError&) {
      // Out of device memory for the larger lists: answer with the frame we have (its overflow
      // is reported) and do not try that size again.
      s.failedListCapacity = s.grownListCapacity;
      s.grownListCapacity = previous;
    }
  }
  return frame;
}

// The frame, top to bottom. Every request (any view, any size) takes this one path.
Frame Renderer::State::renderOnce(SceneBuffers& scene, const FrameSettings& settings) {
  State& s = *this;
  VkExtent2D extent{settings.width, settings.height};
  s.ensureTargets(extent, settings.raw, scene.lightCount);
  s.writeUniforms(settings, scene);
  s.writeSceneSet(scene);
  const FrameTargets& t = *s.targets;
  const LightGrid& grid = *s.grid;
  const Pipelines& p = s.pipelines;

  VkCommandBuffer cmd = gpu::beginCommands(s.context, s.recorder);
  VkDescriptorSet sets[] = {s.sceneSet, s.targetSet, s.cullingSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 3, sets, 0, nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 3, sets, 0, nullptr);
  s.timer.reset(cmd);

  if (settings.animate) {
    s.timer.beginPass(cmd, "animate");
    recordAnimateLights(cmd, p, scene);
    scene.lightsMoved = true;
  } else if (scene.lightsMoved) {
    recordRestoreLights(cmd, scene);
    scene.lightsMoved = false;
  }
  s.timer.beginPass(cmd, "gbuffer");
  recordGBufferPass(cmd, p, t, scene);
  // Lighting leaves HDR and light counts as attachments (volumes) or storage images (compute).
  VkImageLayout lightingLayout = VK_IMAGE_LAYOUT_GENERAL;
  switch (settings.technique) {
    case Technique::Volumes:
      s.timer.beginPass(cmd, "sun");
      recordSunPass(cmd, p, t);
      s.timer.beginPass(cmd, "lights");
      recordLightVolumePass(cmd, p, t, scene);
      lightingLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
      break;
    case Technique::Tiled:
      s.timer.beginPass(cmd, "lighting");
      recordTiledLighting(cmd, p, t, grid);
      break;
    case Technique::Clustered:
      s.timer.beginPass(cmd, "lighting");
      recordClusteredLighting(cmd, p, t, grid, scene);
      break;
  }
  VkImageLayout hdrLayout = lightingLayout;
  if (settings.markers) {
    s.timer.beginPass(cmd, "markers");
    recordMarkerPass(cmd, p, t, scene, hdrLayout);
    hdrLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  }
  s.timer.beginPass(cmd, "tonemap");
  recordTonemapPass(cmd, p, t, hdrLayout, lightingLayout);
  if (settings.target == Target::LightVolumes && !settings.raw) {
    s.timer.beginPass(cmd, "overlay");
    recordLightVolumeOverlayPass(cmd, p, t, scene);
  }
  s.timer.beginPass(cmd, "readback");
  recordReadback(cmd, t);
  if (settings.technique != Technique::Volumes) {
    gpu::bufferBarrier(cmd, grid.stats, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                       VK_ACCESS_2_HOST_READ_BIT);
  }
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
  frame.sceneBytes = scene.bytes();
  CullingReport& report = frame.culling;
  if (settings.technique != Technique::Volumes) {
    CullingStats stats;
    std::memcpy(&stats, grid.stats.mapped, sizeof(stats));
    report.tilesOverflowed = stats.overflow.x;
    report.tileLightsDropped = stats.overflow.y;
    report.clusterLightsDropped = stats.overflow.z;
    report.listEntries = stats.totals.x;
    report.activeClusters = stats.totals.y;
    report.mostLightsInList = stats.totals.z;
  }
  report.lightBytes = scene.lights.size + scene.lightOrigins.size;
  report.listBytes = grid.ranges.size + grid.cursors.size + grid.lists.size;
  report.listCapacity = grid.size.listCapacity;
  return frame;
}

}  // namespace myriad::render
