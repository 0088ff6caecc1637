#include "render/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

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

}  // namespace

struct Renderer::State {
  explicit State(gpu::Context& c)
      : context(c), pipelines(c), uniformArena(c), timer(c, kMaxTimedPasses) {}

  gpu::Context& context;
  Pipelines pipelines;
  gpu::Arena uniformArena;
  gpu::Buffer uniforms;
  gpu::CommandRecorder recorder;
  gpu::PassTimer timer;
  VkSampler sampler = VK_NULL_HANDLE;
  VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
  VkDescriptorSet sceneSet = VK_NULL_HANDLE;
  VkDescriptorSet targetSet = VK_NULL_HANDLE;
  VkDescriptorSet cullingSet = VK_NULL_HANDLE;
  std::unique_ptr<SceneBuffers> sceneBuffers;
  std::unique_ptr<FrameTargets> targets;
  std::unique_ptr<LightGrid> grid;
  bool lightsMoved = false;  // the lights buffer holds animated positions, not the origins
  scene::Sun sun;
  glm::vec3 ambient{0.0f};
  glm::vec3 background{0.0f};

  void writeSceneSet();
  void writeTargetSet();
  void writeCullingSet();
  void writeUniforms(const FrameSettings& settings);
  void ensureTargets(VkExtent2D extent, bool raw);
};

void Renderer::State::writeSceneSet() {
  VkDescriptorBufferInfo buffers[5] = {
      {uniforms.buffer, 0, sizeof(FrameUniforms)},
      {sceneBuffers->lights.buffer, 0, VK_WHOLE_SIZE},
      {sceneBuffers->instances.buffer, 0, VK_WHOLE_SIZE},
      {sceneBuffers->materials.buffer, 0, VK_WHOLE_SIZE},
      {sceneBuffers->lightOrigins.buffer, 0, VK_WHOLE_SIZE},
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

// Targets follow the output size; the light grid follows the size and the light count. Both are
// rebuilt only when they change (every frame is waited for, so nothing is in flight here).
void Renderer::State::ensureTargets(VkExtent2D extent, bool raw) {
  if (!targets || targets->extent.width != extent.width ||
      targets->extent.height != extent.height || targets->raw != raw) {
    targets.reset();
    targets = std::make_unique<FrameTargets>(context, extent, raw);
    writeTargetSet();
  }
  LightGridSize size = lightGridSize(extent, sceneBuffers->lightCount,
                                     context.info.maxStorageBufferRange);
  if (!grid || !(grid->size == size)) {
    grid.reset();
    grid = std::make_unique<LightGrid>(context, size);
    writeCullingSet();
  }
}

void Renderer::State::writeUniforms(const FrameSettings& s) {
  float aspect = float(s.width) / float(s.height);
  glm::mat4 view = scene::viewMatrix(s.camera);
  glm::mat4 projection = scene::projectionMatrix(s.camera, aspect);
  const scene::Bounds& bounds = sceneBuffers->bounds;
  float diagonal = bounds.empty() ? 1.0f : glm::length(bounds.size());

  FrameUniforms u{};
  u.view = view;
  u.projection = projection;
  u.viewProjection = projection * view;
  u.inverseViewProjection = glm::inverse(u.viewProjection);
  u.cameraPosition = glm::vec4(s.camera.eye, 1.0f);
  u.sunDirection = glm::vec4(-glm::normalize(sun.direction), sun.intensity);
  u.sunColor = glm::vec4(sun.color, 0.0f);
  u.ambient = glm::vec4(ambient, 0.0f);
  u.background = glm::vec4(background, 0.0f);
  u.viewport = glm::vec4(s.width, s.height, 1.0f / s.width, 1.0f / s.height);
  // Markers are a fixed fraction of the scene's size: visible in a wide shot, never huge.
  u.camera = glm::vec4(s.exposure, s.camera.nearPlane, s.camera.farPlane, diagonal * 0.0025f);
  u.boundsMin = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.min, 0.0f);
  u.boundsMax = glm::vec4(bounds.empty() ? glm::vec3(1.0f) : bounds.max, 0.0f);
  const LightGridSize& g = grid->size;
  u.flags = glm::uvec4(static_cast<uint32_t>(s.target), sceneBuffers->lightCount, s.raw ? 1 : 0,
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

  setScene(scene::Scene{});
}

Renderer::~Renderer() {
  State& s = *state_;
  vkDeviceWaitIdle(s.context.device);
  s.targets.reset();
  s.grid.reset();
  s.sceneBuffers.reset();
  vkDestroyDescriptorPool(s.context.device, s.descriptorPool, nullptr);
  vkDestroySampler(s.context.device, s.sampler, nullptr);
  gpu::destroyCommandRecorder(s.context, s.recorder);
}

void Renderer::setScene(const scene::Scene& scene) {
  State& s = *state_;
  // Build the new buffers before dropping the old, so a failure leaves the old scene in place.
  auto buffers = std::make_unique<SceneBuffers>(s.context, s.recorder, scene);
  s.sceneBuffers = std::move(buffers);
  s.lightsMoved = false;
  s.sun = scene.sun;
  s.ambient = scene.ambient;
  s.background = scene.background;
  s.writeSceneSet();
}

uint32_t Renderer::maxDimension() const { return state_->context.info.maxImageDimension2D; }

// The frame, top to bottom. Every request (any view, any size) takes this one path.
Frame Renderer::render(const FrameSettings& settings) {
  State& s = *state_;
  if (settings.width == 0 || settings.height == 0 || settings.width > maxDimension() ||
      settings.height > maxDimension()) {
    throw std::invalid_argument("frame size " + std::to_string(settings.width) + "x" +
                                std::to_string(settings.height) + " is outside 1.." +
                                std::to_string(maxDimension()));
  }
  VkExtent2D extent{settings.width, settings.height};
  s.ensureTargets(extent, settings.raw);
  s.writeUniforms(settings);
  const FrameTargets& t = *s.targets;
  const SceneBuffers& scene = *s.sceneBuffers;
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
    s.lightsMoved = true;
  } else if (s.lightsMoved) {
    recordRestoreLights(cmd, scene);
    s.lightsMoved = false;
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
  return frame;
}

}  // namespace myriad::render
