#include "render/motion.h"

#include <array>
#include <span>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "render/raster.h"

namespace myriad::render {

MotionPass::MotionPass(gpu::Context& context, VkDescriptorSetLayout sceneSetLayout, uint32_t slots)
    : context_(context) {
  VkDevice device = context.device;
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_MOTION_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(device, bindings);
  const VkDescriptorSetLayout layouts[] = {sceneSetLayout, setLayout_};
  const VkPushConstantRange push{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                                 sizeof(gpu_types::MotionPush)};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 2;
  info.pSetLayouts = layouts;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &push;
  VK_CHECK(vkCreatePipelineLayout(device, &info, nullptr, &layout_));

  gpu::GraphicsPipelineDesc d;
  d.vertexShader = spirv::motion_vert;
  d.fragmentShader = spirv::motion_frag;
  d.vertexLayout = {sizeof(scene::Vertex),
                    {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
  d.colorFormats = {kRawOutputFormat};
  d.depthFormat = kDepthFormat;
  d.depthTest = true;
  d.depthWrite = false;
  d.depthCompare = VK_COMPARE_OP_EQUAL;
  d.dynamicCullMode = true;
  raw_ = gpu::createGraphicsPipeline(device, layout_, d);
  d.fragmentShader = spirv::motion_view_frag;
  d.colorFormats = {kOutputFormat};
  view_ = gpu::createGraphicsPipeline(device, layout_, d);

  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, slots * MYRIAD_MOTION_BINDINGS};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = slots;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &pool_));
}

MotionPass::~MotionPass() {
  VkDevice device = context_.device;
  for (VkPipeline p : {raw_, view_}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  if (pool_) vkDestroyDescriptorPool(device, pool_, nullptr);
  if (layout_) vkDestroyPipelineLayout(device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device, setLayout_, nullptr);
}

void MotionPass::record(VkCommandBuffer cmd, const FrameTargets& t, const SceneBuffers& scene,
                        VkDescriptorSet sceneSet, const glm::mat4& previousViewProjection,
                        bool previous, const MeshDetail& detail) {
  VkDescriptorSet& set = sets_[sceneSet];
  if (!set) {
    VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    alloc.descriptorPool = pool_;
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &setLayout_;
    VK_CHECK(vkAllocateDescriptorSets(context_.device, &alloc, &set));
  }
  // Without a previous pose the instances are where they are now, and no vertex is read from the
  // previous positions (any storage buffer stands in for them).
  const ScenePosing* posing = previous && scene.posing && scene.posing->motionArena ? scene.posing.get() : nullptr;
  const bool deformed = posing && !posing->posed.empty();
  const VkDescriptorBufferInfo infos[MYRIAD_MOTION_BINDINGS] = {
      {(posing ? posing->previousInstances : scene.instances).buffer, 0, VK_WHOLE_SIZE},
      {(deformed ? posing->vertexRecords : scene.instances).buffer, 0, VK_WHOLE_SIZE},
      {(deformed ? posing->previousPositions : scene.instances).buffer, 0, VK_WHOLE_SIZE}};
  VkWriteDescriptorSet writes[MYRIAD_MOTION_BINDINGS];
  for (uint32_t i = 0; i < MYRIAD_MOTION_BINDINGS; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(context_.device, MYRIAD_MOTION_BINDINGS, writes, 0, nullptr);

  // The output's last use was the previous frame's readback (copy) or its final pass (compute).
  const gpu::ImageTransition before[] = {
      {&t.output, VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
       VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
       VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.output, VK_ATTACHMENT_LOAD_OP_CLEAR);
  color.clearValue.color = {{0.0f, 0.0f, 0.0f, t.raw ? 0.0f : 1.0f}};
  const VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, std::span(&color, 1), &depth);
  bindGeometry(cmd, scene);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, t.raw ? raw_ : view_);
  const VkDescriptorSet sets[] = {sceneSet, set};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 0, 2, sets, 0, nullptr);
  const gpu_types::MotionPush push{previousViewProjection,
                                   glm::uvec4(deformed ? 1u : 0u, t.raw ? 1u : 0u, 0u, 0u)};
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                     sizeof(push), &push);
  uint32_t cull = UINT32_MAX;
  InstancedDraws draws(cmd);
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material]) continue;  // not in the G-buffer's depth
    const uint32_t mode = scene.doubleSided[draw.material] ? 0u : 1u;
    if (mode != cull) {
      draws.flush();
      cull = mode;
      vkCmdSetCullMode(cmd, mode == 0 ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
    }
    const MeshRange mesh = detail.range(scene, draw);
    if (mesh.indexCount == 0) continue;  // outside the view
    draws.add(mesh, draw.instance);
  }
  draws.flush();
  vkCmdEndRendering(cmd);
}

}  // namespace myriad::render
