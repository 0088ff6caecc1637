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
