#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 3: give every cluster its list's place, [start, start + count), from the counts.
// The lists need not follow the clusters' order, only not overlap, so this is not a prefix sum over
// the whole grid in one workgroup: each workgroup takes MYRIAD_SCAN_GROUP x
// MYRIAD_SCAN_CLUSTERS_PER_THREAD consecutive clusters (each thread every MYRIAD_SCAN_GROUP-th of
// them, so reads are coalesced), sums them in shared memory, reserves its part of the lists with
// one atomic (CullingStats.totals.w, the slots handed out so far) and places its clusters in it.
// Lists past the capacity are cut and the dropped indices counted. A cluster's count is the pairs
// the counting pass recorded (its cursor) plus those it did not (clusterSpill); the latter take the
// ranks after the former in the assigning pass, from clusterSpill set to the former's count here.
// Every cursor and cluster number is left MYRIAD_CLUSTER_INACTIVE and the active count 0, as the
// next frame's mark pass wants them.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_SCAN_GROUP) in;

const uint kPerThread = MYRIAD_SCAN_CLUSTERS_PER_THREAD;

shared uint partial[MYRIAD_SCAN_GROUP];
shared uint groupStart;
shared uint groupWritten;
shared uint groupDropped;
shared uint groupActive;
shared uint groupMost;

void main() {
  uint thread = gl_LocalInvocationIndex;
  uint clusters = frame.grid.x * frame.grid.y * frame.grid.z;
  uint first = gl_WorkGroupID.x * MYRIAD_SCAN_GROUP * kPerThread + thread;
  if (thread == 0u) {
    // The active clusters' numbering starts again next frame (the counting pass, its only other
    // reader, is done).
    if (gl_WorkGroupID.x == 0u) clusterCursors[activeCountWord()] = 0u;
    groupWritten = 0u;
    groupDropped = 0u;
    groupActive = 0u;
    groupMost = 0u;
  }

  uint cursors[kPerThread];
  uint sum = 0u;
  uint activeCount = 0u;
  uint most = 0u;
  for (uint k = 0u; k < kPerThread; ++k) {
    uint i = first + k * MYRIAD_SCAN_GROUP;
    cursors[k] = i < clusters ? clusterCursors[i] : MYRIAD_CLUSTER_INACTIVE;
    uint count = cursors[k] == MYRIAD_CLUSTER_INACTIVE ? 0u : cursors[k] + clusterCursors[clusterSpill(i)];
    sum += count;
    most = max(most, count);
    if (cursors[k] != MYRIAD_CLUSTER_INACTIVE) ++activeCount;
  }
  partial[thread] = sum;
  barrier();
  if (activeCount > 0u) atomicAdd(groupActive, activeCount);
  if (most > 0u) atomicMax(groupMost, most);
  // Hillis-Steele inclusive scan of the threads' sums.
  for (uint stride = 1u; stride < MYRIAD_SCAN_GROUP; stride *= 2u) {
    uint add = thread >= stride ? partial[thread - stride] : 0u;
    barrier();
    partial[thread] += add;
    barrier();
  }
  if (thread == MYRIAD_SCAN_GROUP - 1u) groupStart = atomicAdd(stats.totals.w, partial[thread]);
  barrier();

  uint capacity = frame.flags.w;
  uint offset = groupStart + partial[thread] - sum;
  uint written = 0u;
  for (uint k = 0u; k < kPerThread; ++k) {
    uint i = first + k * MYRIAD_SCAN_GROUP;
    if (i >= clusters) break;
    uint count = cursors[k] == MYRIAD_CLUSTER_INACTIVE ? 0u : cursors[k] + clusterCursors[clusterSpill(i)];
    uint start = min(offset, capacity);
    uint kept = min(count, capacity - start);
    clusterRanges[i] = uvec2(start, kept);
    if (cursors[k] != MYRIAD_CLUSTER_INACTIVE) {
      // The pairs not recorded take the ranks after the recorded ones (clusterSpill becomes their
      // fill cursor), and the cursor is inactive again for the next frame's mark: no clearing.
      clusterCursors[clusterSpill(i)] = cursors[k];
      clusterCursors[i] = MYRIAD_CLUSTER_INACTIVE;
      clusterCursors[clusterIdWord(i)] = MYRIAD_CLUSTER_INACTIVE;
    }
    written += kept;
    offset += count;
  }
  if (written > 0u) atomicAdd(groupWritten, written);
  if (sum > written) atomicAdd(groupDropped, sum - written);
  barrier();
  if (thread == 0u) {
    if (groupWritten > 0u) atomicAdd(stats.totals.x, groupWritten);
    if (groupDropped > 0u) atomicAdd(stats.overflow.z, groupDropped);
    if (groupActive > 0u) atomicAdd(stats.totals.y, groupActive);
    atomicMax(stats.totals.z, groupMost);
  }
}
