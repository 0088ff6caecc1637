// The passes that make and read back the output: the final pass (tonemapping, or a view of a
// target), anti-aliasing, the light-volumes overlay, the readback copies and the YCbCr planes.
#include "render/passes.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <utility>
#include <vector>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/raster.h"
#include "markers.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::ImageTransition;

// From the image's last use (an attachment's or a storage image's write) to sampling by compute
// (the final and views passes).
ImageTransition sampledByCompute(const gpu::Image& image, const ImageState& last) {
  return {&image, last.stage, last.access, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, last.layout, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

}  // namespace

VkExtent2D finalPassGroups(const Pipelines& p, const FrameTargets& t, Target target) {
  const bool picture = target == Target::Final || target == Target::LightVolumes;
  const uint32_t group = picture && !t.raw ? p.finalGroup : MYRIAD_PIXEL_GROUP;
  return {gpu::groupCount(t.extent.width, group), gpu::groupCount(t.extent.height, group)};
}

void recordFinalPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t, Target target,
                     bool markers, bool antialias, const ImageState& hdr,
                     const ImageState& lightCount, uint32_t first, uint32_t count) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  const bool picture = target == Target::Final || target == Target::LightVolumes;
  const VkPipeline pipeline = picture ? (t.raw ? p.finalRaw : p.finalFor(antialias, markers))
                                      : p.viewsFor(target, t.raw);
  const VkExtent2D groups = finalPassGroups(p, t, target);
  if (first > 0) {
    // A later range of a split frame's pass: the first range made the layouts and the edge list.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    gpu::dispatchGroupRange(cmd, groups.width, groups.height, first, count);
    return;
  }
  std::vector<ImageTransition> before = {
      sampledByCompute(t.hdr, hdr),
      sampledByCompute(t.lightCount, lightCount),
      // The previous frame's last use of the output was the readback copy.
      // (or, for a YCbCr frame, the conversion's loads).
      {&t.output, VK_PIPELINE_STAGE_2_COPY_BIT | kCompute, VK_ACCESS_2_NONE, kCompute,
       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
  };
  // The final shader binds the keys and (8-bit) the LDR target whether or not this frame uses
  // them, so they get their layout either way. Their previous contents are not needed: the keys
  // were last read by the previous final pass, the LDR target sampled by the previous
  // anti-aliasing pass.
  if (picture && !markers) {
    before.push_back({&t.markerKeys, kCompute, VK_ACCESS_2_NONE, kCompute,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_GENERAL});
  }
  if (picture && !t.raw) {
    before.push_back({&t.ldr, kCompute, VK_ACCESS_2_NONE, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  }
  gpu::barrier(cmd, before);
  if (picture && !t.raw) {
    // The edge list starts empty (the previous anti-aliasing pass read it, as its dispatch's
    // arguments and from the shader).
    gpu::bufferBarrier(cmd, t.edges,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const gpu_types::AntialiasEdges empty{{0, 1, 1, 0}, {0, 0, 0, 0}};
    vkCmdUpdateBuffer(cmd, t.edges.buffer, 0, sizeof(empty), &empty);
    gpu::bufferBarrier(cmd, t.edges, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  gpu::dispatchGroupRange(cmd, groups.width, groups.height, 0, count);
}

void recordAntialiasPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  // The output is already GENERAL (recordFinalPass); the final pass wrote the pixels off edges,
  // this pass writes the listed ones (disjoint, so no barrier on the output between them).
  const ImageTransition before[] = {{&t.ldr, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute,
                                     VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                     VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, before);
  if (p.antialiasEdges) {
    // CPU devices: the edge test, from the LDR target (final_pass.glsl's CPU main), which lists
    // the edge pixels and writes the others to the output.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.antialiasEdges);
    vkCmdDispatch(cmd, gpu::groupCount(t.extent.width, p.finalGroup),
                  gpu::groupCount(t.extent.height, p.finalGroup), 1);
  }
  gpu::bufferBarrier(cmd, t.edges, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     kCompute | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.antialias);
  vkCmdDispatchIndirect(cmd, t.edges.buffer, 0);
}

void recordLightVolumeOverlayPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                                  const SceneBuffers& scene) {
  // The final pass stored the dimmed picture; blending reads and writes it.
  const ImageTransition before[] = {
      {&t.output, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
       VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.output, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.lightVolumeOverlay);
  drawLightProxies(cmd, scene);
  vkCmdEndRendering(cmd);
}

namespace {

// Copies the whole of `image` (last written at `writer` with `written`, in `layout`) into
// `readback`, rows top first, and makes it visible to the host.
void copyToReadback(VkCommandBuffer cmd, const gpu::Image& image, VkExtent2D extent,
                    VkPipelineStageFlags2 writer, VkAccessFlags2 written, VkImageLayout layout,
                    const gpu::Buffer& readback) {
  const ImageTransition before[] = {{&image, writer, written, VK_PIPELINE_STAGE_2_COPY_BIT,
                                     VK_ACCESS_2_TRANSFER_READ_BIT, layout,
                                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent.width, extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer,
                         1, &region);
  gpu::bufferBarrier(cmd, readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace

void recordLabelReadback(VkCommandBuffer cmd, const FrameTargets& t, const gpu::Buffer& readback) {
  copyToReadback(cmd, t.labels, t.extent, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                 VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                 readback);
}

void recordReadback(VkCommandBuffer cmd, const FrameTargets& t, const ImageState& output,
                    const gpu::Buffer& readback) {
  copyToReadback(cmd, t.output, t.extent, output.stage, output.access, output.layout, readback);
}

void recordYuv420Readback(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                          const ImageState& output, const gpu::Buffer& readback) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  // The final (and anti-aliasing) pass, or a registered pass, stored the output; this pass
  // loads it.
  const ImageTransition before[] = {{&t.output, output.stage, output.access, kCompute,
                                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT, output.layout,
                                     VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, before);
  const Yuv420Layout layout = yuv420Layout(t.extent.width, t.extent.height);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.yuv420);
  vkCmdDispatch(cmd, gpu::groupCount(layout.yStride / 8, MYRIAD_PIXEL_GROUP),
                gpu::groupCount(layout.rows / 2, MYRIAD_PIXEL_GROUP), 1);
  gpu::bufferBarrier(cmd, t.planes, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  const VkBufferCopy region{0, 0, layout.bytes()};
  vkCmdCopyBuffer(cmd, t.planes.buffer, readback.buffer, 1, &region);
  gpu::bufferBarrier(cmd, readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace myriad::render
