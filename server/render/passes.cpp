#include "render/passes.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::ImageTransition;

gpu::VertexLayout fullVertexLayout() {
  return {sizeof(scene::Vertex),
          {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
           {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
           {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}}};
}

gpu::VertexLayout positionOnlyLayout() {
  return {sizeof(scene::Vertex),
          {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
}

VkRenderingAttachmentInfo colorAttachment(const gpu::Image& image, VkAttachmentLoadOp load) {
  VkRenderingAttachmentInfo a{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  a.imageView = image.view;
  a.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  a.loadOp = load;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  return a;
}

// The G-buffer depth as a read-only attachment: depth-tested against, never written or cleared.
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
  if (scene.lightCount == 0) return;
  bindGeometry(cmd, scene);
  vkCmdDrawIndexed(cmd, scene.lightProxy.indexCount, scene.lightCount, scene.lightProxy.firstIndex,
                   scene.lightProxy.vertexOffset, 0);
}

// Blending reads the attachment, so consecutive blending passes need write -> read/write.
ImageTransition colorWriteToBlend(const gpu::Image& image) {
  return {&image,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
}

// Images are rewritten from scratch each frame (old contents discarded); the previous frame's
// last use was a fragment-shader read, which must finish before the new writes (write-after-read).
ImageTransition discardForColorWrite(const gpu::Image& image, VkPipelineStageFlags2 lastReader) {
  return {&image, lastReader, VK_ACCESS_2_NONE,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
}

// G-buffer images are read by fragment shaders (sun, light volumes, tonemap views) and by the
// compute lighting of the tiled and clustered techniques.
ImageTransition colorWriteToSampled(const gpu::Image& image) {
  return {&image,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

// After a compute pass stored into an image, before a raster pass writes it as an attachment.
ImageTransition storageWriteToColorWrite(const gpu::Image& image) {
  return {&image, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
}

// From whichever kind of write produced the image (attachment or storage) to sampling.
ImageTransition writtenToSampled(const gpu::Image& image, VkImageLayout layout) {
  if (layout == VK_IMAGE_LAYOUT_GENERAL) {
    return {&image, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
            VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
            VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
  }
  return colorWriteToSampled(image);
}

}  // namespace

Pipelines::Pipelines(gpu::Context& context) : device(context.device) {
  // The largest workgroups: the cluster scan's 1D group and the tiled shader's 2D tile.
  const gpu::DeviceInfo& limits = context.info;
  const uint32_t largestGroup =
      std::max<uint32_t>(MYRIAD_SCAN_GROUP, MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE);
  if (limits.maxComputeWorkGroupInvocations < largestGroup ||
      limits.maxComputeWorkGroupSizeX < MYRIAD_SCAN_GROUP) {
    throw std::runtime_error(limits.name + " runs compute workgroups of at most " +
                             std::to_string(limits.maxComputeWorkGroupInvocations) +
                             " invocations; Myriad's light culling needs " +
                             std::to_string(largestGroup) + ".");
  }
  const VkShaderStageFlags all =
      VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
  std::array<VkDescriptorSetLayoutBinding, 5> sceneBindings{{
      {MYRIAD_BINDING_FRAME, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_INSTANCES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_MATERIALS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHT_ORIGINS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
  }};
  sceneSetLayout = gpu::createDescriptorSetLayout(device, sceneBindings);
  const VkShaderStageFlags readers = VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
  std::array<VkDescriptorSetLayoutBinding, 9> targetBindings{};
  for (uint32_t i = 0; i <= MYRIAD_BINDING_LIGHT_COUNT; ++i) {
    targetBindings[i] = {i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, readers, nullptr};
  }
  targetBindings[MYRIAD_BINDING_HDR_STORAGE] = {MYRIAD_BINDING_HDR_STORAGE,
                                                VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                                VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetBindings[MYRIAD_BINDING_LIGHT_COUNT_STORAGE] = {MYRIAD_BINDING_LIGHT_COUNT_STORAGE,
                                                        VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                                        VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetSetLayout = gpu::createDescriptorSetLayout(device, targetBindings);
  std::array<VkDescriptorSetLayoutBinding, 4> cullingBindings{};
  for (uint32_t i = 0; i < cullingBindings.size(); ++i) {
    cullingBindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  cullingSetLayout = gpu::createDescriptorSetLayout(device, cullingBindings);
  VkDescriptorSetLayout setLayouts[] = {sceneSetLayout, targetSetLayout, cullingSetLayout};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 3;
  layoutInfo.pSetLayouts = setLayouts;
  VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &layout));

  gpu::GraphicsPipelineDesc d;
  d.vertexShader = spirv::gbuffer_vert;
  d.fragmentShader = spirv::gbuffer_frag;
  d.vertexLayout = fullVertexLayout();
  d.colorFormats = {kNormalFormat, kBaseColorFormat, kMaterialFormat, kUvFormat};
  d.depthFormat = kDepthFormat;
  d.depthTest = d.depthWrite = true;
  d.depthCompare = VK_COMPARE_OP_LESS;
  gbuffer = gpu::createGraphicsPipeline(device, layout, d);

  d = {};
  d.vertexShader = spirv::fullscreen_vert;
  d.fragmentShader = spirv::sun_frag;
  d.colorFormats = {kHdrFormat, kLightCountFormat};
  sun = gpu::createGraphicsPipeline(device, layout, d);

  // Light volumes draw the sphere's BACK faces: exactly one fragment per covered pixel whether
  // the camera is outside the sphere, inside it, or the sphere crosses the near plane (its far
  // side is still in front of the camera). GREATER_OR_EQUAL keeps pixels whose surface lies in
  // front of the far side; the shader then tests the exact distance. Depth clamp keeps far sides
  // beyond the far plane from being clipped away.
  d = {};
  d.vertexShader = spirv::light_volume_vert;
  d.fragmentShader = spirv::light_volume_frag;
  d.vertexLayout = positionOnlyLayout();
  d.colorFormats = {kHdrFormat, kLightCountFormat};
  d.blend = gpu::Blend::Additive;
  d.depthFormat = kDepthFormat;
  d.depthTest = true;
  d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
  d.depthClamp = context.depthClamp;
  d.cullMode = VK_CULL_MODE_FRONT_BIT;
  lightVolumes = gpu::createGraphicsPipeline(device, layout, d);

  d.fragmentShader = spirv::light_volume_overlay_frag;
  d.colorFormats = {kOutputFormat};
  lightVolumeOverlay = gpu::createGraphicsPipeline(device, layout, d);

  d = {};
  d.vertexShader = spirv::marker_vert;
  d.fragmentShader = spirv::marker_frag;
  d.vertexLayout = fullVertexLayout();
  d.colorFormats = {kHdrFormat};
  d.depthFormat = kDepthFormat;
  d.depthTest = true;
  d.depthCompare = VK_COMPARE_OP_LESS_OR_EQUAL;
  d.cullMode = VK_CULL_MODE_BACK_BIT;
  markers = gpu::createGraphicsPipeline(device, layout, d);

  d = {};
  d.vertexShader = spirv::fullscreen_vert;
  d.fragmentShader = spirv::tonemap_frag;
  d.colorFormats = {kOutputFormat};
  tonemap = gpu::createGraphicsPipeline(device, layout, d);
  d.colorFormats = {kRawOutputFormat};
  tonemapRaw = gpu::createGraphicsPipeline(device, layout, d);

  animateLights = gpu::createComputePipeline(device, layout, spirv::light_animate_comp);
  tiledLighting = gpu::createComputePipeline(device, layout, spirv::light_tiled_comp);
  clusterMark = gpu::createComputePipeline(device, layout, spirv::cluster_mark_comp);
  clusterScan = gpu::createComputePipeline(device, layout, spirv::cluster_scan_comp);
  clusteredLighting = gpu::createComputePipeline(device, layout, spirv::light_clustered_comp);
  // cluster_assign.comp counts (kAssign = false) or fills the lists (true): one source, so both
  // passes run the identical overlap test.
  VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
  for (VkBool32 assign : {VK_FALSE, VK_TRUE}) {
    VkSpecializationInfo spec{1, &entry, sizeof(VkBool32), &assign};
    VkPipeline& target = assign ? clusterAssign : clusterCount;
    target = gpu::createComputePipeline(device, layout, spirv::cluster_assign_comp, &spec);
  }
}

Pipelines::~Pipelines() {
  for (VkPipeline p : {gbuffer, sun, lightVolumes, lightVolumeOverlay, markers, tonemap, tonemapRaw,
                       animateLights, tiledLighting, clusterMark, clusterCount, clusterScan,
                       clusterAssign, clusteredLighting}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  if (layout) vkDestroyPipelineLayout(device, layout, nullptr);
  if (sceneSetLayout) vkDestroyDescriptorSetLayout(device, sceneSetLayout, nullptr);
  if (targetSetLayout) vkDestroyDescriptorSetLayout(device, targetSetLayout, nullptr);
  if (cullingSetLayout) vkDestroyDescriptorSetLayout(device, cullingSetLayout, nullptr);
}

void recordGBufferPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                       const SceneBuffers& scene) {
  const VkPipelineStageFlags2 reader = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  const ImageTransition before[] = {
      discardForColorWrite(t.normal, reader),
      discardForColorWrite(t.baseColor, reader),
      discardForColorWrite(t.material, reader),
      discardForColorWrite(t.uv, reader),
      {&t.depth, reader | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL},
  };
  gpu::barrier(cmd, before);

  std::array<VkRenderingAttachmentInfo, 4> colors = {
      colorAttachment(t.normal, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.baseColor, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.material, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.uv, VK_ATTACHMENT_LOAD_OP_CLEAR)};
  for (auto& c : colors) c.clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depth.imageView = t.depth.view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  beginRendering(cmd, t.extent, colors, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.gbuffer);
  bindGeometry(cmd, scene);
  for (const DrawItem& draw : scene.draws) {
    vkCmdDrawIndexed(cmd, draw.mesh.indexCount, 1, draw.mesh.firstIndex, draw.mesh.vertexOffset,
                     draw.instance);
  }
  vkCmdEndRendering(cmd);

  const ImageTransition after[] = {
      colorWriteToSampled(t.normal),
      colorWriteToSampled(t.baseColor),
      colorWriteToSampled(t.material),
      colorWriteToSampled(t.uv),
      {&t.depth, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
           VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
       VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL},
  };
  gpu::barrier(cmd, after);
}

void recordSunPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t) {
  const ImageTransition before[] = {
      discardForColorWrite(t.hdr, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT),
      discardForColorWrite(t.lightCount, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT)};
  gpu::barrier(cmd, before);
  // Every pixel is written (background included), so nothing is loaded or cleared.
  std::array<VkRenderingAttachmentInfo, 2> colors = {
      colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_DONT_CARE),
      colorAttachment(t.lightCount, VK_ATTACHMENT_LOAD_OP_DONT_CARE)};
  beginRendering(cmd, t.extent, colors, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.sun);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  vkCmdEndRendering(cmd);
}

void recordLightVolumePass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                           const SceneBuffers& scene) {
  const ImageTransition before[] = {colorWriteToBlend(t.hdr), colorWriteToBlend(t.lightCount)};
  gpu::barrier(cmd, before);
  std::array<VkRenderingAttachmentInfo, 2> colors = {
      colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_LOAD),
      colorAttachment(t.lightCount, VK_ATTACHMENT_LOAD_OP_LOAD)};
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, colors, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.lightVolumes);
  drawLightProxies(cmd, scene);
  vkCmdEndRendering(cmd);
}

void recordMarkerPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                      const SceneBuffers& scene, VkImageLayout hdrLayout) {
  const ImageTransition before[] = {hdrLayout == VK_IMAGE_LAYOUT_GENERAL
                                        ? storageWriteToColorWrite(t.hdr)
                                        : colorWriteToBlend(t.hdr)};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.markers);
  drawLightProxies(cmd, scene);
  vkCmdEndRendering(cmd);
}

void recordTonemapPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                       VkImageLayout hdrLayout, VkImageLayout lightCountLayout) {
  const ImageTransition before[] = {
      writtenToSampled(t.hdr, hdrLayout),
      writtenToSampled(t.lightCount, lightCountLayout),
      // The previous frame's last use of the output was the readback copy.
      {&t.output, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
  };
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.output, VK_ATTACHMENT_LOAD_OP_DONT_CARE);
  beginRendering(cmd, t.extent, {&color, 1}, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, t.raw ? p.tonemapRaw : p.tonemap);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  vkCmdEndRendering(cmd);
}

void recordLightVolumeOverlayPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                                  const SceneBuffers& scene) {
  const ImageTransition before[] = {colorWriteToBlend(t.output)};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.output, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.lightVolumeOverlay);
  drawLightProxies(cmd, scene);
  vkCmdEndRendering(cmd);
}

void recordReadback(VkCommandBuffer cmd, const FrameTargets& t) {
  const ImageTransition before[] = {
      {&t.output, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
       VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
       VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {t.extent.width, t.extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, t.output.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                         t.readback.buffer, 1, &region);
  gpu::bufferBarrier(cmd, t.readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace myriad::render
