#include "render/frame_targets.h"

#include <algorithm>

#include "render/cluster_grid.h"
#include "render/gpu_types.h"

namespace myriad::render {

namespace {
// Blocks sized to small frames: a 64 MiB default block per memory type would make a 320x180
// frame hold 128 MiB. An image larger than a block gets a block of its own size.
constexpr VkDeviceSize kTargetBlockSize = 4ull << 20;
}  // namespace

FrameTargets::FrameTargets(gpu::Context& context, VkExtent2D size, bool rawOutput,
                           const ClusterGrid& clusters, bool computeWritable_)
    : extent(size), raw(rawOutput), computeWritable(computeWritable_),
      arena(context, kTargetBlockSize), context_(&context) {
  const VkImageUsageFlags gbufferUsage =
      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
  const VkImageUsageFlags computeUsage = computeWritable ? VK_IMAGE_USAGE_STORAGE_BIT : 0;
  depth = arena.createImage2D(extent, kDepthFormat,
                              VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                  (computeWritable ? VK_IMAGE_USAGE_TRANSFER_DST_BIT : 0));
  normal = arena.createImage2D(extent, kNormalFormat, gbufferUsage | computeUsage);
  if (computeWritable) {
    // sRGB formats are not storage formats: compute stores through a UNORM view and encodes.
    baseColor = arena.createImage2D(extent, kBaseColorFormat, gbufferUsage | computeUsage, 1,
                                    VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT |
                                        VK_IMAGE_CREATE_EXTENDED_USAGE_BIT);
    baseColorStorage = arena.createView(baseColor, kBaseColorStorageFormat, VK_IMAGE_USAGE_STORAGE_BIT);
  } else {
    baseColor = arena.createImage2D(extent, kBaseColorFormat, gbufferUsage);
  }
  material = arena.createImage2D(extent, kMaterialFormat, gbufferUsage | computeUsage);
  uv = arena.createImage2D(extent, kUvFormat, gbufferUsage | computeUsage);
  emissive = arena.createImage2D(extent, kEmissiveFormat, gbufferUsage | computeUsage);
  // Not written by compute: a scene with layers takes the raster G-buffer
  // (ComputeGBuffer::qualifies).
  layers = arena.createImage2D(extent, kLayersFormat, gbufferUsage);
  // Compute lighting (tiled, clustered) stores into these; volumes blend into them.
  hdr = arena.createImage2D(extent, kHdrFormat, gbufferUsage | VK_IMAGE_USAGE_STORAGE_BIT);
  lightCount = arena.createImage2D(extent, kLightCountFormat, gbufferUsage | VK_IMAGE_USAGE_STORAGE_BIT);
  markerKeys = arena.createImage2D(extent, kMarkerKeyFormat,
                                   VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
  // 4 bytes per pixel, kept for raw frames too (which never anti-alias) so that every binding of
  // the target set always holds an image.
  ldr = arena.createImage2D(extent, kLdrFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  output = arena.createImage2D(extent, raw ? kRawOutputFormat : kOutputFormat,
                               VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                   VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  const VkDeviceSize edgePixels = raw ? 1 : VkDeviceSize(extent.width) * extent.height;
  // Whole pairs of words: the numbering pass's workgroups take 64 clusters each. Then six words
  // per cluster: the bounds of its points (shaders/cluster_bounds.glsl).
  clusterMarks = arena.createBuffer((VkDeviceSize(clusters.count()) + 63) / 64 * 8 +
                                        VkDeviceSize(clusters.count()) * 24,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                    gpu::MemoryUse::DeviceLocal);
  edges = arena.createBuffer(sizeof(gpu_types::AntialiasEdges) + edgePixels * 4,
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                 VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                             gpu::MemoryUse::DeviceLocal);
  const VkDeviceSize planeBytes = raw ? 16 : yuv420Layout(extent.width, extent.height).bytes();
  planes = arena.createBuffer(planeBytes,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              gpu::MemoryUse::DeviceLocal);
  const VkDeviceSize pixelBytes = VkDeviceSize(extent.width) * extent.height * (raw ? 16 : 4);
  readback = arena.createBuffer(std::max(pixelBytes, raw ? 0 : planeBytes),
                                VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUse::Readback);
}

void FrameTargets::ensureLabels() {
  if (labels.image != VK_NULL_HANDLE) return;
  labels = arena.createImage2D(extent, kLabelFormat,
                               VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
}

void FrameTargets::ensureExtras(uint32_t regions) {
  if (!raw && extraOutput.image == VK_NULL_HANDLE) {
    extraOutput = arena.createImage2D(extent, kRawOutputFormat,
                                      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  }
  if (regions <= extraRegions) return;
  // Nothing in flight uses the old buffer: the slot is being prepared for its next frame.
  extraReadback = {};
  extraArena.reset();
  extraArena = std::make_unique<gpu::Arena>(*context_, regionBytes() * regions);
  extraReadback = extraArena->createBuffer(regionBytes() * regions, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                           gpu::MemoryUse::Readback);
  extraRegions = regions;
}

}  // namespace myriad::render
