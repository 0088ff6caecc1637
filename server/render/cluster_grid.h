// The cluster grid of an output: 64x64-pixel screen tiles x 32 exponential depth slices between
// near and far (MYRIAD_CLUSTER_*). The clustered technique's lists and the clusters view
// (views_pass.glsl) both use it, through FrameUniforms.grid and .slicing.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <cstring>

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

// The tiles' size in pixels: MYRIAD_CLUSTER_TILE_SIZE, or 32 or 16 with MYRIAD_CLUSTER_TILE=32|16
// in the environment (a benchmark experiment: the shading pass's tiles divide each).
inline uint32_t clusterTileSize() {
  static const uint32_t size = [] {
    const char* v = std::getenv("MYRIAD_CLUSTER_TILE");
    if (v && std::strcmp(v, "32") == 0) return 32u;
    if (v && std::strcmp(v, "16") == 0) return 16u;
    return uint32_t(MYRIAD_CLUSTER_TILE_SIZE);
  }();
  return size;
}

// The depth slices: MYRIAD_CLUSTER_SLICES, or MYRIAD_CLUSTER_SLICE_COUNT from the environment
// (16 to 128; a benchmark experiment: thinner slices shorten the lists and add clusters).
inline uint32_t clusterSlices() {
  static const uint32_t slices = [] {
    const char* v = std::getenv("MYRIAD_CLUSTER_SLICE_COUNT");
    const long n = v ? std::strtol(v, nullptr, 10) : 0;
    return n >= 16 && n <= 128 ? uint32_t(n) : uint32_t(MYRIAD_CLUSTER_SLICES);
  }();
  return slices;
}

inline ClusterGrid clusterGrid(VkExtent2D extent) {
  const uint32_t tile = clusterTileSize();
  return {(extent.width + tile - 1) / tile, (extent.height + tile - 1) / tile, clusterSlices()};
}

}  // namespace myriad::render
