#include "render/tuning.h"

#include <algorithm>

#include "gpu/device_info.h"
#include "shared_types.h"

namespace myriad::render {

// The header keeps its defaults as numbers (service/ includes it without the shader headers);
// they must be the shaders' own.
static_assert(Tuning{}.clusterTile == MYRIAD_CLUSTER_TILE_SIZE);
static_assert(Tuning{}.clusterSlices == MYRIAD_CLUSTER_SLICES);
static_assert(Tuning{}.assignBins == MYRIAD_ASSIGN_BINS);
static_assert(Tuning{}.assignMostClusters == MYRIAD_LARGE_LIGHT_CLUSTERS);
static_assert(Tuning{}.shadeVariant == MYRIAD_SHADE_DEFAULT);
// The shading pass's tiles divide every cluster tile --tune allows.
static_assert(16 % MYRIAD_CLUSTER_SHADE_TILE == 0);

Tuning resolveTuning(const Tuning& asked, const gpu::DeviceInfo& device) {
  Tuning t = asked;
  // The binned passes and the subgroup shading walk need full subgroups with arithmetic, ballot
  // and shuffle; without them the per-pair and per-pixel paths run whatever was asked.
  const bool subgroups = device.computeSubgroupShuffle;
  if (t.assign == AssignPath::Auto) t.assign = device.isCpu ? AssignPath::PerPair : AssignPath::Binned;
  if (!subgroups) t.assign = AssignPath::PerPair;

  if (t.shade == ShadePass::Auto) {
    t.shade = device.isCpu ? ShadePass::WholeWhenShort
                           : subgroups ? ShadePass::Subgroup : ShadePass::Pixel;
  }
  if (t.shade == ShadePass::Subgroup && !subgroups) t.shade = ShadePass::Pixel;

  // Halved while the device runs no groups that large, never below MYRIAD_ASSIGN_BIN_GROUP (the
  // technique requires it).
  const uint32_t most = std::min(device.maxComputeWorkGroupInvocations, device.maxComputeWorkGroupSizeX);
  while (t.assignGroupSize > MYRIAD_ASSIGN_BIN_GROUP && t.assignGroupSize > most) {
    t.assignGroupSize /= 2;
  }

  if (!t.assignGroups) t.assignGroups = device.multiprocessors > 0 ? device.multiprocessors : 128u;
  if (!t.pointTest) t.pointTest = device.isCpu ? 0u : 2u;
  if (!t.sunScroll) t.sunScroll = device.isCpu;
  return t;
}

}  // namespace myriad::render
