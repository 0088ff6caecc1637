#include "render/renderer.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// gbuffer, sun, lights, markers, tonemap, overlay, readback.
constexpr uint32_t kMaxTimedPasses = 8;

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
  std::unique_ptr<SceneBuffers> sceneBuffers;
  std::unique_ptr<FrameTargets> targets;
  scene::Sun sun;
  glm::vec3 ambient{0.0f};
  glm::vec3 background{0.0f};

  void writeSceneSet();
  void writeTargetSet();
  void writeUniforms(const FrameSettings& settings);
};

void Renderer::State::writeSceneSet() {
  VkDescriptorBufferInfo buffers[4] = {
      {uniforms.buffer, 0, sizeof(FrameUniforms)},
      {sceneBuffers->lights.buffer, 0, VK_WHOLE_SIZE},
      {sceneBuffers->instances.buffer, 0, VK_WHOLE_SIZE},
      {sceneBuffers->materials.buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[4];
  for (uint32_t i = 0; i < 4; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = sceneSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        i == MYRIAD_BINDING_FRAME ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  vkUpdateDescriptorSets(context.device, 4, writes, 0, nullptr);
}

void Renderer::State::writeTargetSet() {
  const gpu::Image* images[6] = {&targets->depth,    &targets->normal, &targets->baseColor,
                                 &targets->material, &targets->uv,     &targets->hdr};
  VkDescriptorImageInfo infos[6];
  VkWriteDescriptorSet writes[6];
  for (uint32_t i = 0; i < 6; ++i) {
    infos[i] = {sampler, images[i]->view, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = targetSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &infos[i];
  }
  vkUpdateDescriptorSets(context.device, 6, writes, 0, nullptr);
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
  u.camera = glm::vec4(s.exposure, s.camera.nearPlane, s.camera.farPlane, diagonal * 0.004f);
  u.boundsMin = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.min, 0.0f);
  u.boundsMax = glm::vec4(bounds.empty() ? glm::vec3(1.0f) : bounds.max, 0.0f);
  u.flags = glm::uvec4(static_cast<uint32_t>(s.target), sceneBuffers->lightCount, 0, 0);
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
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3},
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 6}};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 3;
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

  setScene(scene::Scene{});
}

Renderer::~Renderer() {
  State& s = *state_;
  vkDeviceWaitIdle(s.context.device);
  s.targets.reset();
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
  if (!s.targets || s.targets->extent.width != extent.width ||
      s.targets->extent.height != extent.height) {
    s.targets.reset();  // the previous frame finished (we wait for every frame)
    s.targets = std::make_unique<FrameTargets>(s.context, extent);
    s.writeTargetSet();
  }
  s.writeUniforms(settings);
  const FrameTargets& t = *s.targets;
  const SceneBuffers& scene = *s.sceneBuffers;
  const Pipelines& p = s.pipelines;

  VkCommandBuffer cmd = gpu::beginCommands(s.context, s.recorder);
  VkDescriptorSet sets[] = {s.sceneSet, s.targetSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 2, sets, 0, nullptr);
  s.timer.reset(cmd);

  s.timer.beginPass(cmd, "gbuffer");
  recordGBufferPass(cmd, p, t, scene);
  s.timer.beginPass(cmd, "sun");
  recordSunPass(cmd, p, t);
  s.timer.beginPass(cmd, "lights");
  recordLightVolumePass(cmd, p, t, scene);
  if (settings.markers) {
    s.timer.beginPass(cmd, "markers");
    recordMarkerPass(cmd, p, t, scene);
  }
  s.timer.beginPass(cmd, "tonemap");
  recordTonemapPass(cmd, p, t);
  if (settings.target == Target::LightVolumes) {
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
  frame.rgba.resize(size_t(extent.width) * extent.height * 4);
  std::memcpy(frame.rgba.data(), t.readback.mapped, frame.rgba.size());
  for (auto& [name, ms] : s.timer.results()) frame.passes.push_back({name, ms});
  return frame;
}

}  // namespace myriad::render
