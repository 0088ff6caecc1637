// The clustered technique's grid and lists, and the culling counters every compute technique
// writes. Sized from the output size (clusters) and the light count (list capacity); recreated
// when either outgrows it.
#pragma once

#include <cstdint>

#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "gpu/resources.h"

namespace myriad::render {

struct LightGridSize {
  uint32_t clustersX = 0;
  uint32_t clustersY = 0;
  uint32_t slices = 0;
  uint32_t listCapacity = 0;  // light references all cluster lists together can hold

  uint32_t clusterCount() const { return clustersX * clustersY * slices; }
  bool operator==(const LightGridSize&) const = default;
};

// The grid for an output of `extent` with `lightCount` lights, on a device whose storage buffers
// hold at most `maxStorageBytes`.
LightGridSize lightGridSize(VkExtent2D extent, uint32_t lightCount, uint64_t maxStorageBytes);

struct LightGrid {
  LightGrid(gpu::Context& context, const LightGridSize& size);

  LightGridSize size;
  gpu::Arena arena;
  gpu::Buffer ranges;   // uvec2 per cluster
  gpu::Buffer cursors;  // uint per cluster
  gpu::Buffer lists;    // uint per light reference
  gpu::Buffer stats;    // CullingStats, host-visible: read back after the frame
};

}  // namespace myriad::render
