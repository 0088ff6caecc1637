#include "render/raster.h"

#include <algorithm>
#include <cstddef>

#include "embedded_shaders.h"
#include "render/frame_targets.h"
#include "scene/scene.h"

namespace myriad::render {

VkRenderingAttachmentInfo colorAttachment(const gpu::Image& image, VkAttachmentLoadOp load) {
  VkRenderingAttachmentInfo a{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  a.imageView = image.view;
  a.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  a.loadOp = load;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  return a;
}

VkRenderingAttachmentInfo readOnlyDepth(const gpu::Image& depth) {
  VkRenderingAttachmentInfo a{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  a.imageView = depth.view;
  a.imageLayout = VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL;
  a.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  a.storeOp = VK_ATTACHMENT_STORE_OP_NONE;
  return a;
}

void beginRendering(VkCommandBuffer cmd, VkExtent2D extent,
                    std::span<const VkRenderingAttachmentInfo> colors,
                    const VkRenderingAttachmentInfo* depth) {
  VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
  info.renderArea = {{0, 0}, extent};
  info.layerCount = 1;
  info.colorAttachmentCount = static_cast<uint32_t>(colors.size());
  info.pColorAttachments = colors.data();
  info.pDepthAttachment = depth;
  vkCmdBeginRendering(cmd, &info);
  VkViewport viewport{0.0f, 0.0f, float(extent.width), float(extent.height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, extent};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void bindGeometry(VkCommandBuffer cmd, const SceneBuffers& scene) {
  VkDeviceSize offset = 0;
  vkCmdBindVertexBuffers(cmd, 0, 1, &scene.vertices.buffer, &offset);
  vkCmdBindIndexBuffer(cmd, scene.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
}

void drawLightProxies(VkCommandBuffer cmd, const SceneBuffers& scene) {
  drawLightProxies(cmd, scene, 0, scene.lightCount);
}

void drawLightProxies(VkCommandBuffer cmd, const SceneBuffers& scene, uint32_t first,
                      uint32_t count) {
  if (first >= scene.lightCount) return;
  count = std::min(count, scene.lightCount - first);
  if (count == 0) return;
  bindGeometry(cmd, scene);
  vkCmdDrawIndexed(cmd, scene.lightProxy.indexCount, count, scene.lightProxy.firstIndex,
                   scene.lightProxy.vertexOffset, first);
}

gpu::ImageTransition colorWriteToBlend(const gpu::Image& image) {
  return {&image,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
}

gpu::ImageTransition discardForColorWrite(const gpu::Image& image, VkPipelineStageFlags2 lastReader) {
  return {&image, lastReader, VK_ACCESS_2_NONE,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
}

// Light volumes draw the sphere's BACK faces: exactly one fragment per covered pixel whether the
// camera is outside the sphere, inside it, or the sphere crosses the near plane (its far side is
// still in front of the camera). GREATER_OR_EQUAL keeps pixels whose surface lies in front of the
// far side; the shader then tests the exact distance. Depth clamp keeps far sides beyond the far
// plane from being clipped away.
gpu::GraphicsPipelineDesc lightVolumeDesc(const gpu::Context& context) {
  gpu::GraphicsPipelineDesc d;
  d.vertexShader = spirv::light_volume_vert;
  d.vertexLayout = {sizeof(scene::Vertex),
                    {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
  d.blend = gpu::Blend::Additive;
  d.depthFormat = kDepthFormat;
  d.depthTest = true;
  d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
  d.depthClamp = context.depthClamp;
  d.cullMode = VK_CULL_MODE_FRONT_BIT;
  return d;
}

void InstancedDraws::add(const MeshRange& range, uint32_t instance) {
  if (count_ > 0 && range.firstIndex == range_.firstIndex && range.indexCount == range_.indexCount &&
      range.vertexOffset == range_.vertexOffset && instance == first_ + count_) {
    ++count_;
    return;
  }
  flush();
  range_ = range;
  first_ = instance;
  count_ = 1;
}

void InstancedDraws::flush() {
  if (count_ == 0) return;
  vkCmdDrawIndexed(cmd_, range_.indexCount, count_, range_.firstIndex, range_.vertexOffset, first_);
  count_ = 0;
  ++draws_;
}

}  // namespace myriad::render
