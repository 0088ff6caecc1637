#include "render/light_grid.h"

#include <algorithm>

#include "render/gpu_types.h"

namespace myriad::render {

namespace {

// Light references per light the lists are sized for. A light small next to a 64-pixel tile
// touches 1-4 tiles and 1-2 slices; lights near the camera touch many more but are few. Eight per
// light covered the built-in scenes at every tested size with room to spare (the culling report
// says when it does not); the floor keeps small scenes from being starved by a few huge lights.
constexpr uint32_t kReferencesPerLight = 8;
constexpr uint32_t kMinimumListCapacity = 1u << 18;
// References per cluster of the whole grid. Per light alone is not enough when the lights are
// dense or the output large: on the H200 the lists overflowed at 3840x2160 with 10,000 and
// 100,000 floor lights and at 1920x1080 in the built-in scene with 10,000 (docs/performance.md),
// needing 400-450 references per active cluster. About 4-5% of clusters hold geometry in those
// views, so 32 per grid cluster leaves 650-800 per active one: 2 MiB at 1080p, 8 MiB at 4K.
constexpr uint32_t kReferencesPerCluster = 32;

// The grid's buffers are a few MiB at most sizes; the 64 MiB default block would be mostly waste.
constexpr VkDeviceSize kGridBlockSize = 4ull << 20;

}  // namespace

LightGridSize lightGridSize(VkExtent2D extent, uint32_t lightCount, uint64_t maxStorageBytes) {
  LightGridSize size;
  size.clustersX = (extent.width + MYRIAD_CLUSTER_TILE_SIZE - 1) / MYRIAD_CLUSTER_TILE_SIZE;
  size.clustersY = (extent.height + MYRIAD_CLUSTER_TILE_SIZE - 1) / MYRIAD_CLUSTER_TILE_SIZE;
  size.slices = MYRIAD_CLUSTER_SLICES;
  uint64_t wanted = std::max({uint64_t(kMinimumListCapacity), uint64_t(lightCount) * kReferencesPerLight,
                               uint64_t(size.clusterCount()) * kReferencesPerCluster});
  // lavapipe caps a storage buffer at 128 MiB: 32M references. Overflow beyond is reported.
  size.listCapacity = static_cast<uint32_t>(std::min<uint64_t>(wanted, maxStorageBytes / sizeof(uint32_t)));
  return size;
}

LightGrid::LightGrid(gpu::Context& context, const LightGridSize& s)
    : size(s), arena(context, kGridBlockSize) {
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  ranges = arena.createBuffer(VkDeviceSize(size.clusterCount()) * 8, storage, gpu::MemoryUse::DeviceLocal);
  cursors = arena.createBuffer(VkDeviceSize(size.clusterCount()) * 4,
                               storage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUse::DeviceLocal);
  lists = arena.createBuffer(VkDeviceSize(size.listCapacity) * 4, storage, gpu::MemoryUse::DeviceLocal);
  stats = arena.createBuffer(sizeof(CullingStats), storage | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                             gpu::MemoryUse::Readback);
}

}  // namespace myriad::render
