// The cluster grid of an output: 64x64-pixel screen tiles x 32 exponential depth slices between
// near and far (MYRIAD_CLUSTER_*). The clustered technique's lists and the clusters view
// (views_pass.glsl) both use it, through FrameUniforms.grid and .slicing.
#pragma once

#include <cstdint>

#include <vulkan/vulkan.h>

#include "shared_types.h"

namespace myriad::render {

struct ClusterGrid {
  uint32_t x = 0;  // clusters across
  uint32_t y = 0;  // clusters down
  uint32_t slices = 0;

  uint32_t count() const { return x * y * slices; }
  bool operator==(const ClusterGrid&) const = default;
};

inline ClusterGrid clusterGrid(VkExtent2D extent) {
  return {(extent.width + MYRIAD_CLUSTER_TILE_SIZE - 1) / MYRIAD_CLUSTER_TILE_SIZE,
          (extent.height + MYRIAD_CLUSTER_TILE_SIZE - 1) / MYRIAD_CLUSTER_TILE_SIZE,
          MYRIAD_CLUSTER_SLICES};
}

}  // namespace myriad::render
