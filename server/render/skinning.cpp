#include "render/skinning.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "render/scene_buffers.h"

namespace myriad::render {

static_assert(sizeof(scene::Vertex) == MYRIAD_VERTEX_FLOATS * sizeof(float));
static_assert(offsetof(scene::Vertex, normal) == 3 * sizeof(float) &&
              offsetof(scene::Vertex, tangent) == 8 * sizeof(float));
static_assert(sizeof(gpu_types::SkinJob) == 48 && sizeof(gpu_types::SkinPush) == 16);
static_assert(sizeof(gpu_types::MotionPush) == 80);


SkinningPass::SkinningPass(gpu::Context& context) : context_(context) {
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_SKIN_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(context.device, bindings);
  const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(gpu_types::SkinPush)};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &setLayout_;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &push;
  VK_CHECK(vkCreatePipelineLayout(context.device, &info, nullptr, &layout_));
  pipeline_ = gpu::createComputePipeline(context.device, layout_, spirv::skinning_comp);
}

SkinningPass::~SkinningPass() {
  if (pipeline_) vkDestroyPipeline(context_.device, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(context_.device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(context_.device, setLayout_, nullptr);
}

bool SkinningPass::needed(const SceneBuffers& scene, bool previous) {
  const ScenePosing* p = scene.posing.get();
  if (!p || p->posed.empty()) return false;
  return p->dirty || (previous && p->motionArena && p->previousDirty);
}

void SkinningPass::ensureSets(SceneBuffers& scene) {
  ScenePosing& p = *scene.posing;
  if (p.pool) return;
  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * MYRIAD_SKIN_BINDINGS};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(context_.device, &poolInfo, nullptr, &p.pool));
  const VkDescriptorSetLayout layouts[] = {setLayout_, setLayout_};
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = p.pool;
  alloc.descriptorSetCount = 2;
  alloc.pSetLayouts = layouts;
  VkDescriptorSet sets[2];
  VK_CHECK(vkAllocateDescriptorSets(context_.device, &alloc, sets));
  p.currentSet = sets[0];
  p.previousSet = sets[1];
  // Without motion buffers the previous set is never bound; its bindings name the current
  // pose and the jobs (any storage buffer: the current mode never writes PREVIOUS).
  const gpu::Buffer& previousPositions = p.motionArena ? p.previousPositions : p.jobs;
  const gpu::Buffer& previousPose = p.motionArena ? p.previousPose : p.pose;
  for (int s = 0; s < 2; ++s) {
    const VkDescriptorBufferInfo infos[MYRIAD_SKIN_BINDINGS] = {
        {scene.vertices.buffer, 0, VK_WHOLE_SIZE}, {p.influences.buffer, 0, VK_WHOLE_SIZE},
        {p.morphs.buffer, 0, VK_WHOLE_SIZE},       {p.targets.buffer, 0, VK_WHOLE_SIZE},
        {p.jobs.buffer, 0, VK_WHOLE_SIZE},
        {(s == 0 ? p.pose : previousPose).buffer, 0, VK_WHOLE_SIZE},
        {previousPositions.buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet writes[MYRIAD_SKIN_BINDINGS];
    for (uint32_t i = 0; i < MYRIAD_SKIN_BINDINGS; ++i) {
      writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[i].dstSet = sets[s];
      writes[i].dstBinding = i;
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(context_.device, MYRIAD_SKIN_BINDINGS, writes, 0, nullptr);
  }
}

void SkinningPass::record(VkCommandBuffer cmd, SceneBuffers& scene, bool previous,
                          gpu::PassTimer& timer) {
  if (!needed(scene, previous)) return;
  ScenePosing& p = *scene.posing;
  ensureSets(scene);  // (SceneBuffers refused a scene whose vertices one range cannot reach)
  timer.beginPass(cmd, "skin");
  // Earlier readers of the regions (vertex input, the compute G-buffer, the motion pass) and the
  // pre-pass's own earlier writes come first.
  gpu::memoryBarrier(cmd,
                     VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
  const uint32_t jobs = static_cast<uint32_t>(p.posed.size());
  const uint32_t groupsX = gpu::groupCount(p.mostVertices, MYRIAD_SKIN_GROUP);
  auto dispatch = [&](VkDescriptorSet set, uint32_t mode) {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
    // Workgroup counts past 65535 are not guaranteed: jobs in batches.
    for (uint32_t first = 0; first < jobs; first += 65535u) {
      const gpu_types::SkinPush push{glm::uvec4(mode, first, 0u, 0u)};
      vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      vkCmdDispatch(cmd, groupsX, std::min(jobs - first, 65535u), 1);
    }
  };
  if (p.dirty) {
    dispatch(p.currentSet, 0);
    p.dirty = false;
  }
  if (previous && p.motionArena && p.previousDirty) {
    dispatch(p.previousSet, 1);
    p.previousDirty = false;
  }
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT |
                         VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

}  // namespace myriad::render

