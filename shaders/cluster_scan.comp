#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 3: exclusive prefix sum of the per-cluster counts into list offsets, in one
// workgroup (a few tens of thousands of clusters: each thread sums a contiguous run, then the
// workgroup scans the run totals in shared memory). Lists past the capacity are cut and the
// dropped indices counted. Active clusters' cursors are reset to 0 for the assigning pass.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_SCAN_GROUP) in;

shared uint partial[MYRIAD_SCAN_GROUP];
shared uint activeTotal;
shared uint mostLights;

void main() {
  uint thread = gl_LocalInvocationIndex;
  uint clusters = frame.grid.x * frame.grid.y * frame.grid.z;
  uint run = (clusters + MYRIAD_SCAN_GROUP - 1u) / MYRIAD_SCAN_GROUP;
  uint first = min(thread * run, clusters);
  uint last = min(first + run, clusters);
  if (thread == 0u) {
    activeTotal = 0u;
    mostLights = 0u;
  }

  uint sum = 0u;
  uint activeCount = 0u;
  uint most = 0u;
  for (uint i = first; i < last; ++i) {
    uint cursor = clusterCursors[i];
    uint count = cursor == MYRIAD_CLUSTER_INACTIVE ? 0u : cursor;
    sum += count;
    most = max(most, count);
    if (cursor != MYRIAD_CLUSTER_INACTIVE) ++activeCount;
  }
  partial[thread] = sum;
  barrier();
  atomicAdd(activeTotal, activeCount);
  atomicMax(mostLights, most);
  // Hillis-Steele inclusive scan of the run totals.
  for (uint stride = 1u; stride < MYRIAD_SCAN_GROUP; stride *= 2u) {
    uint add = thread >= stride ? partial[thread - stride] : 0u;
    barrier();
    partial[thread] += add;
    barrier();
  }

  uint capacity = frame.flags.w;
  uint offset = partial[thread] - sum;
  for (uint i = first; i < last; ++i) {
    uint cursor = clusterCursors[i];
    uint count = cursor == MYRIAD_CLUSTER_INACTIVE ? 0u : cursor;
    uint start = min(offset, capacity);
    clusterRanges[i] = uvec2(start, min(count, capacity - start));
    if (cursor != MYRIAD_CLUSTER_INACTIVE) clusterCursors[i] = 0u;
    offset += count;
  }
  if (thread == MYRIAD_SCAN_GROUP - 1u) {
    uint total = partial[thread];
    stats.totals.x = min(total, capacity);
    stats.overflow.z = total > capacity ? total - capacity : 0u;
  }
  barrier();
  if (thread == 0u) {
    stats.totals.y = activeTotal;
    stats.totals.z = max(stats.totals.z, mostLights);
  }
}
