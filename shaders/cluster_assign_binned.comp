#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered steps 2 and 4 for the small lights, counted per workgroup before any global atomic.
//
// cluster_assign.comp adds one global atomic per light-cluster pair; with a million lights the
// pairs of a frame fall on a few hundred active clusters, thousands on the busiest, and those
// atomics on one address are serialised. Here a workgroup takes a contiguous run of lights and
// counts its pairs per cluster in shared memory first (a hash table of MYRIAD_ASSIGN_BINS
// clusters, linear probing), then adds each cluster's total to the global cursor once:
// - counting pass (kAssign = false): the totals are the clusters' counts;
// - assigning pass (kAssign = true, after the prefix sum): the global add reserves the
//   workgroup's part of each list, and the lights are walked again, each pair taking the next
//   slot of that part from shared memory.
// A cluster the table cannot hold (full after MYRIAD_ASSIGN_PROBES probes) takes the global atomic
// per pair, as before: the table is only ever filled, so a pass finds a cluster in it exactly when
// its first walk put it there. Counts are exact either way; the order within a list is whatever the
// atomics give, as in cluster_assign.comp. Lights reaching more than MYRIAD_LARGE_LIGHT_CLUSTERS
// clusters are queued for the per-workgroup pass of cluster_assign.comp (kLarge), as there.
#include "frame.glsl"
#include "compute_targets.glsl"
#include "cluster_assign.glsl"

layout(local_size_x = MYRIAD_ASSIGN_BIN_GROUP) in;
layout(constant_id = 0) const bool kAssign = false;

const uint kGroup = MYRIAD_ASSIGN_BIN_GROUP;
const uint kBins = MYRIAD_ASSIGN_BINS;
const uint kEmpty = 0xFFFFFFFFu;  // a free bin's cluster
const uint kNoBin = 0xFFFFFFFFu;

shared uint binCluster[kBins];
shared uint binCount[kBins];  // pairs counted; in the assigning pass, then the next free slot

// The bin holding `cluster`, claiming a free one if `claim`; kNoBin if it is not (or cannot be)
// in the table.
uint findBin(uint cluster, bool claim) {
  uint h = (cluster * 2654435761u) >> 16u;
  for (uint p = 0u; p < MYRIAD_ASSIGN_PROBES; ++p) {
    uint bin = (h + p) & (kBins - 1u);
    uint held = claim ? atomicCompSwap(binCluster[bin], kEmpty, cluster) : binCluster[bin];
    if (held == cluster || (claim && held == kEmpty)) return bin;
    if (held == kEmpty) return kNoBin;  // looking up: bins fill in probe order, so it is absent
  }
  return kNoBin;
}

// First walk: count the light's pairs in the table (or, counting, globally when it is full).
void countLight(uint index) {
  LightClusters b;
  if (index >= frame.flags.y || !lightClusters(index, b)) return;
  if (b.clusters > MYRIAD_LARGE_LIGHT_CLUSTERS) {
    if (!kAssign) {
      uint slot = atomicAdd(largeQueue.queued.x, 1u);
      largeLights[slot] = index;
      atomicMax(largeQueue.groups.x, min(slot + 1u, MYRIAD_LARGE_LIGHT_GROUPS));
    }
    return;
  }
  for (uint i = 0u; i < b.clusters; ++i) {
    uint cluster;
    if (!lightReachesCluster(b, i, cluster)) continue;
    uint bin = findBin(cluster, true);
    if (bin != kNoBin) {
      atomicAdd(binCount[bin], 1u);
    } else if (!kAssign) {
      atomicAdd(clusterCursors[cluster], 1u);
    }
  }
}

// Second walk (assigning): each pair takes a slot of the workgroup's reserved part, or a global
// one for a cluster outside the table.
void placeLight(uint index) {
  LightClusters b;
  if (index >= frame.flags.y || !lightClusters(index, b)) return;
  if (b.clusters > MYRIAD_LARGE_LIGHT_CLUSTERS) return;
  for (uint i = 0u; i < b.clusters; ++i) {
    uint cluster;
    if (!lightReachesCluster(b, i, cluster)) continue;
    uint bin = findBin(cluster, false);
    uint slot = bin != kNoBin ? atomicAdd(binCount[bin], 1u) : atomicAdd(clusterCursors[cluster], 1u);
    uvec2 range = clusterRanges[cluster];
    if (slot < range.y) clusterLights[range.x + slot] = index;
  }
}

void main() {
  uint thread = gl_LocalInvocationIndex;
  for (uint bin = thread; bin < kBins; bin += kGroup) {
    binCluster[bin] = kEmpty;
    binCount[bin] = 0u;
  }
  barrier();
  // This group's lights: a contiguous run, kGroup consecutive lights per step (coalesced reads).
  uint lightCount = frame.flags.y;
  uint steps = (lightCount + gl_NumWorkGroups.x * kGroup - 1u) / (gl_NumWorkGroups.x * kGroup);
  uint first = gl_WorkGroupID.x * steps * kGroup + thread;
  for (uint k = 0u; k < steps; ++k) countLight(first + k * kGroup);
  barrier();
  for (uint bin = thread; bin < kBins; bin += kGroup) {
    uint count = binCount[bin];
    if (count == 0u) continue;
    uint start = atomicAdd(clusterCursors[binCluster[bin]], count);
    if (kAssign) binCount[bin] = start;
  }
  if (!kAssign) return;
  barrier();
  for (uint k = 0u; k < steps; ++k) placeLight(first + k * kGroup);
}
