// What the raster passes share (passes.cpp, techniques/volumes.cpp): dynamic-rendering
// attachments, the image transitions between them, and the light proxy spheres.
#pragma once

#include <span>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/pipelines.h"
#include "gpu/resources.h"
#include "render/scene_buffers.h"

namespace myriad::render {

VkRenderingAttachmentInfo colorAttachment(const gpu::Image& image, VkAttachmentLoadOp load);

// The G-buffer depth as a read-only attachment: depth-tested against, never written or cleared.
VkRenderingAttachmentInfo readOnlyDepth(const gpu::Image& depth);

// Begins dynamic rendering over the whole of `extent`, with viewport and scissor to match.
void beginRendering(VkCommandBuffer cmd, VkExtent2D extent,
                    std::span<const VkRenderingAttachmentInfo> colors,
                    const VkRenderingAttachmentInfo* depth);

void bindGeometry(VkCommandBuffer cmd, const SceneBuffers& scene);

// Records draws of the scene's instances as few instanced draws: consecutive draws of the same
// index range whose instances follow each other (the objects of one asset, placed one after
// another in the instance buffer by SceneGraph::flatten) become one vkCmdDrawIndexed with
// instanceCount > 1; gl_InstanceIndex still names each instance. The same pixels as one draw
// each: the instances are drawn in the same order. Call flush() before any state change (a
// pipeline, a descriptor set, a cull mode) and before the rendering ends.
class InstancedDraws {
 public:
  explicit InstancedDraws(VkCommandBuffer cmd) : cmd_(cmd) {}
  ~InstancedDraws() { flush(); }
  InstancedDraws(const InstancedDraws&) = delete;
  InstancedDraws& operator=(const InstancedDraws&) = delete;

  void add(const MeshRange& range, uint32_t instance);
  void flush();
  uint32_t draws() const { return draws_; }  // vkCmdDrawIndexed calls so far

 private:
  VkCommandBuffer cmd_;
  MeshRange range_{};
  uint32_t first_ = 0;
  uint32_t count_ = 0;
  uint32_t draws_ = 0;
};

// Every vertex attribute (position, normal, uv, tangent, colour): what gbuffer.vert reads, for the
// G-buffer pass and every pass that rasterises the scene's surfaces with it.
gpu::VertexLayout surfaceVertexLayout();

// One instanced draw of the light proxy sphere per light (nothing without lights); with `first`
// and `count`, of lights [first, first + count) only (firstInstance carries the light index).
void drawLightProxies(VkCommandBuffer cmd, const SceneBuffers& scene);
void drawLightProxies(VkCommandBuffer cmd, const SceneBuffers& scene, uint32_t first,
                      uint32_t count);

// Blending reads the attachment, so consecutive blending passes need write -> read/write.
gpu::ImageTransition colorWriteToBlend(const gpu::Image& image);

// Images are rewritten from scratch each frame (old contents discarded); the previous frame's
// last use was a read by `lastReader`, which must finish before the new writes (write-after-read).
gpu::ImageTransition discardForColorWrite(const gpu::Image& image, VkPipelineStageFlags2 lastReader);

// A pipeline drawing the light proxies as volumes: their BACK faces, depth-tested
// GREATER_OR_EQUAL against the read-only G-buffer depth, additive, depth clamped where the device
// can (raster.cpp says why). The fragment shader and colour formats are the caller's.
gpu::GraphicsPipelineDesc lightVolumeDesc(const gpu::Context& context);

}  // namespace myriad::render
