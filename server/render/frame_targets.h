// The images one frame renders into, sized to the requested output (never a fixed size), and the
// host buffer the output is read back through. Recreated together when the size changes.
#pragma once

#include <vulkan/vulkan.h>

#include <memory>

#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/cluster_grid.h"

namespace myriad::render {

// G-buffer formats. Normals are octahedral in two 16-bit signed-normalised channels (about 0.002
// degrees of error); base colour is sRGB so 8 bits hold dark shades well; metallic, roughness and
// occlusion (R, G, B of the material target) are [0,1] values, fine in 8 bits; uvs may leave
// [0,1], so they are half floats; emitted radiance is HDR (factor x strength x texture), so half
// floats too (RGBA16F: B10G11R11 would do, but is not a guaranteed colour attachment).
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
inline constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16_SNORM;
inline constexpr VkFormat kBaseColorFormat = VK_FORMAT_R8G8B8A8_SRGB;
inline constexpr VkFormat kBaseColorStorageFormat = VK_FORMAT_R8G8B8A8_UNORM;  // compute's view
inline constexpr VkFormat kMaterialFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kUvFormat = VK_FORMAT_R16G16_SFLOAT;
inline constexpr VkFormat kEmissiveFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
// Clear coat and sheen (material_core.glsl's gbufferTexels): six [0,1] values in 8 bits each,
// packed as two packUnorm4x8 words (one target: RGBA8 holds four, and integer RG32 is a
// guaranteed colour attachment and sampled format).
inline constexpr VkFormat kLayersFormat = VK_FORMAT_R32G32_UINT;
inline constexpr VkFormat kHdrFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
inline constexpr VkFormat kOutputFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kRawOutputFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
// Lights that shaded each pixel: exact integers up to 2^24 in a float, and blendable (volumes add 1).
inline constexpr VkFormat kLightCountFormat = VK_FORMAT_R32_SFLOAT;
// The markers pass's per-pixel keys (shaders/markers.h): storage-image atomics on R32_UINT are
// required of every Vulkan device, lavapipe included.
inline constexpr VkFormat kMarkerKeyFormat = VK_FORMAT_R32_UINT;
// The tonemapped final image before anti-aliasing: sRGB-encoded colour and its luma in alpha,
// the form the anti-aliasing pass compares and blends (storage write, linear-filtered reads).
inline constexpr VkFormat kLdrFormat = VK_FORMAT_R8G8B8A8_UNORM;
// The label pass's target: object id, semantic class, material id, 1 where a surface is. The same
// 16 bytes a pixel as kRawOutputFormat, so it is read back through the raw readback buffer.
inline constexpr VkFormat kLabelFormat = VK_FORMAT_R32G32B32A32_UINT;

struct FrameTargets {
  // `raw`: the output holds float values (kRawOutputFormat) instead of an 8-bit image.
  // `computeWritable`: the G-buffer may also be written by compute (render/visibility.h): its
  // colour targets are storage images too (base colour through a UNORM view) and depth a copy
  // destination. Only then: storage may cost a GPU its render-target compression.
  // `clusters`: the cluster grid of `extent` (render/cluster_grid.h), for the cluster marks.
  FrameTargets(gpu::Context& context, VkExtent2D extent, bool raw, const ClusterGrid& clusters,
               bool computeWritable = false);

  VkExtent2D extent;
  bool raw;
  bool computeWritable;
  gpu::Arena arena;
  gpu::Image depth;
  gpu::Image normal;
  gpu::Image baseColor;
  VkImageView baseColorStorage = VK_NULL_HANDLE;  // RGBA8_UNORM view (computeWritable only)
  gpu::Image material;
  gpu::Image uv;
  gpu::Image emissive;
  gpu::Image layers;  // written only for scenes with a clear coat or a sheen (raster path only)
  gpu::Image hdr;
  gpu::Image lightCount;
  gpu::Image markerKeys;
  gpu::Image ldr;     // final, tonemapped, before anti-aliasing (kLdrFormat)
  gpu::Image output;  // written by compute (storage); the light-volumes overlay blends onto it
  // The label pass's target (kLabelFormat): made by ensureLabels() for the first label frame of
  // raw targets, kept with them (16 bytes a pixel only for sessions that ask for labels).
  gpu::Image labels;
  void ensureLabels();
  // AntialiasEdges, then a uint per pixel: the pixels the final pass lists for anti-aliasing (a
  // header and one pixel for raw targets, which never anti-alias, so the binding always holds one).
  gpu::Buffer edges;
  // The output as YCbCr 4:2:0 planes (yuv420Layout; 8-bit targets; a 16-byte stand-in for raw).
  gpu::Buffer planes;
  // A bit per cluster of the extent's grid (render/cluster_grid.h), set where the cluster holds
  // visible geometry: by the compute G-buffer's resolve when the clustered technique asks
  // (FrameUniforms.written.z), else by its own pixel pass; its numbering pass reads and clears
  // them. After the bits, six words per cluster: the world bounds of its surface points, gathered
  // by the same passes (shaders/cluster_bounds.glsl) and read and zeroed by the numbering. Per
  // frame slot, so a frame's G-buffer never writes what an earlier frame in flight still reads;
  // cleared once when made (clusterMarksFresh), then by each frame's reader.
  gpu::Buffer clusterMarks;
  bool clusterMarksFresh = true;
  gpu::Buffer readback;  // output pixels, rows top first (RGBA, floats, or the planes)

  // A multi-target frame's (FrameSettings::alsoRead; render/extra_targets.h): `regions` raw
  // views of 16 bytes a pixel, one after another in `extraReadback` (its own arena, made again
  // larger when a frame needs more regions), and, for an 8-bit main output, `extraOutput`
  // (kRawOutputFormat) the raw views are written to instead of `output`. Made on first use, kept
  // with the targets.
  void ensureExtras(uint32_t regions);
  gpu::Image extraOutput;
  std::unique_ptr<gpu::Arena> extraArena;
  gpu::Buffer extraReadback;
  uint32_t extraRegions = 0;
  VkDeviceSize regionBytes() const { return VkDeviceSize(extent.width) * extent.height * 16; }
  // Memory of everything above and the extras.
  VkDeviceSize bytesAllocated() const {
    return arena.bytesAllocated() + (extraArena ? extraArena->bytesAllocated() : 0);
  }

 private:
  gpu::Context* context_;
};

}  // namespace myriad::render
