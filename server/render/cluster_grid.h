// The cluster grid of an output: 64x64-pixel screen tiles x 32 exponential depth slices between
// near and far (MYRIAD_CLUSTER_*; --tune cluster-tile and cluster-slices change them:
// render/tuning.h). The clustered technique's lists and the clusters view (views_pass.glsl) both
// use it, through FrameUniforms.grid and .slicing.
#pragma once

#include <cstdint>

#include <vulkan/vulkan.h>

#include "render/tuning.h"

namespace myriad::render {

struct ClusterGrid {
  uint32_t x = 0;  // clusters across
  uint32_t y = 0;  // clusters down
  uint32_t slices = 0;

  uint32_t count() const { return x * y * slices; }
  bool operator==(const ClusterGrid&) const = default;
};

// The grid of an output of `extent`: `tuning.clusterTile`-pixel tiles (MYRIAD_CLUSTER_TILE_SIZE
// unless --tune cluster-tile says otherwise) x `tuning.clusterSlices` slices.
inline ClusterGrid clusterGrid(VkExtent2D extent, const Tuning& tuning) {
  const uint32_t tile = tuning.clusterTile;
  return {(extent.width + tile - 1) / tile, (extent.height + tile - 1) / tile, tuning.clusterSlices};
}

}  // namespace myriad::render
