// The raster passes every technique shares: the G-buffer, the labels, the alpha-blended
// surfaces; and the light markers' splat. The output's passes are in output_passes.cpp.
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

// G-buffer images are read by fragment shaders (sun, light volumes, forward) and by compute (the
// lighting of the tiled and clustered techniques, markers, the final and views passes).
ImageTransition colorWriteToSampled(const gpu::Image& image) {
  return {&image,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

}  // namespace

void recordGBufferPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                       const SceneBuffers& scene, uint32_t written, const MeshDetail& detail) {
  // Last frame's readers: the raster lighting (fragment) and compute lighting and views (compute).
  const VkPipelineStageFlags2 reader =
      VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  const ImageTransition before[] = {
      discardForColorWrite(t.normal, reader),
      discardForColorWrite(t.baseColor, reader),
      discardForColorWrite(t.material, reader),
      discardForColorWrite(t.uv, reader),
      discardForColorWrite(t.emissive, reader),
      discardForColorWrite(t.layers, reader),
      {&t.depth, reader | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL},
  };
  gpu::barrier(cmd, before);

  std::array<VkRenderingAttachmentInfo, 6> colors = {
      colorAttachment(t.normal, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.baseColor, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.material, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.uv, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.emissive, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.layers, VK_ATTACHMENT_LOAD_OP_CLEAR)};  // uint: cleared to 0 words
  for (auto& c : colors) c.clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};
  // Optional targets the frame does not read are left unbound: their writes are discarded (and
  // their contents undefined; FrameUniforms.written tells the shaders).
  if ((written & MYRIAD_GBUFFER_UV) == 0) colors[3].imageView = VK_NULL_HANDLE;
  if ((written & MYRIAD_GBUFFER_EMISSIVE) == 0) colors[4].imageView = VK_NULL_HANDLE;
  if ((written & MYRIAD_GBUFFER_LAYERS) == 0) colors[5].imageView = VK_NULL_HANDLE;
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depth.imageView = t.depth.view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  beginRendering(cmd, t.extent, colors, &depth);
  bindGeometry(cmd, scene);
  // Opaque materials first, then alpha-tested ones (their own pipeline: a shader that may discard
  // writes depth only after it runs). Draws come grouped by material (SceneBuffers sorts them):
  // one texture set and one cull mode per group.
  // Opaque materials without textures draw with gbufferUntextured (gbuffer.glsl says why).
  InstancedDraws draws(cmd);
  for (const bool alphaTest : {false, true}) {
    VkPipeline pipelineBound = VK_NULL_HANDLE;
    uint32_t bound = UINT32_MAX;
    for (const DrawItem& draw : scene.draws) {
      if (scene.blend[draw.material]) continue;  // the forward pass draws it (recordBlendPass)
      if ((scene.alphaTest[draw.material] != 0) != alphaTest) continue;
      const VkPipeline pipeline = alphaTest                        ? p.gbufferAlphaTest
                                  : scene.textured[draw.material] ? p.gbuffer
                                                                  : p.gbufferUntextured;
      if (pipeline != pipelineBound) {
        draws.flush();
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        pipelineBound = pipeline;
      }
      if (draw.material != bound) {
        draws.flush();
        bound = draw.material;
        VkDescriptorSet set = scene.textures->set(bound);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout,
                                MYRIAD_SET_MATERIAL, 1, &set, 0, nullptr);
        vkCmdSetCullMode(cmd, scene.doubleSided[bound] ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
      }
      const MeshRange mesh = detail.range(scene, draw);
      if (mesh.indexCount == 0) continue;  // outside the view
      draws.add(mesh, draw.instance);
    }
    draws.flush();
  }
  vkCmdEndRendering(cmd);

  const ImageTransition after[] = {
      colorWriteToSampled(t.normal),
      colorWriteToSampled(t.baseColor),
      colorWriteToSampled(t.material),
      colorWriteToSampled(t.uv),
      colorWriteToSampled(t.emissive),
      colorWriteToSampled(t.layers),
      {&t.depth, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
           VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
       VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL},
  };
  gpu::barrier(cmd, after);
}

bool hasBlendDraws(const SceneBuffers& scene) {
  return std::any_of(scene.draws.begin(), scene.draws.end(),
                     [&](const DrawItem& d) { return scene.blend[d.material] != 0; });
}

VkImageLayout recordBlendPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                              const SceneBuffers& scene, const glm::mat4& view,
                              VkImageLayout hdrLayout, bool clusterLists) {
  // Back to front: the farthest centre (most negative view-space z) first; ties keep scene order.
  std::vector<std::pair<float, const DrawItem*>> order;
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material]) order.emplace_back((view * glm::vec4(draw.centre, 1.0f)).z, &draw);
  }
  if (order.empty()) return hdrLayout;
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  const bool storage = hdrLayout == VK_IMAGE_LAYOUT_GENERAL;
  const ImageTransition before[] = {
      storage ? ImageTransition{&t.hdr, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                                VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT |
                                    VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}
              : colorWriteToBlend(t.hdr)};
  gpu::barrier(cmd, before);
  if (clusterLists) {
    // The lists were filled by compute (the clustered technique's assign step).
    gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  }
  VkRenderingAttachmentInfo color = colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, clusterLists ? p.forwardClustered : p.forward);
  bindGeometry(cmd, scene);
  uint32_t bound = UINT32_MAX;
  for (const auto& [z, draw] : order) {
    if (draw->material != bound) {
      bound = draw->material;
      VkDescriptorSet set = scene.textures->set(bound);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, MYRIAD_SET_MATERIAL,
                              1, &set, 0, nullptr);
      vkCmdSetCullMode(cmd, scene.doubleSided[bound] ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
    }
    vkCmdDrawIndexed(cmd, draw->mesh.indexCount, 1, draw->mesh.firstIndex, draw->mesh.vertexOffset,
                     draw->instance);
  }
  vkCmdEndRendering(cmd);
  return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
}

void recordMarkerPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                      const SceneBuffers& scene) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  constexpr VkAccessFlags2 kReadWrite =
      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  // Keys: the previous frame's final pass read them; clear to 0 (no marker).
  const ImageTransition clear[] = {{&t.markerKeys, kCompute, VK_ACCESS_2_NONE,
                                    VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                    VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL}};
  gpu::barrier(cmd, clear);
  const VkClearColorValue zero{};
  VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdClearColorImage(cmd, t.markerKeys.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &range);
  const ImageTransition splat[] = {{&t.markerKeys, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                                    VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite,
                                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, splat);
  // Depth is already readable by compute (recordGBufferPass); lights by every stage.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.markerSplat);
  if (scene.lightCount > 0) {
    vkCmdDispatch(cmd, gpu::groupCount(scene.lightCount, MYRIAD_LIGHTS_PER_GROUP), 1, 1);
  }
  // The final pass reads the keys (its resolve).
  const ImageTransition resolve[] = {
      {&t.markerKeys, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute,
       VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, resolve);
}

void recordLabelPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                     const SceneBuffers& scene, const MeshDetail& detail) {
  const ImageTransition before[] = {
      {&t.labels, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.labels, VK_ATTACHMENT_LOAD_OP_CLEAR);
  color.clearValue.color.uint32[0] = color.clearValue.color.uint32[1] = 0;
  color.clearValue.color.uint32[2] = color.clearValue.color.uint32[3] = 0;
  const VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, std::span(&color, 1), &depth);
  bindGeometry(cmd, scene);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.labels);
  uint32_t cull = UINT32_MAX;
  InstancedDraws draws(cmd);
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material]) continue;  // not in the G-buffer: no label
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
