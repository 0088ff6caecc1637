#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered steps 2 and 4 for the small lights: each light's clusters are walked once a frame.
//
// Counting pass (kAssign = false; with kAnimate it moves the lights first, see below). A workgroup takes a contiguous run of lights and counts its
// light-cluster pairs per cluster in shared memory (a hash table of kBins clusters, linear
// probing), then adds each cluster's total to the cluster's global cursor once, so that a million
// lights do not serialise on the busiest clusters' atomics. Every pair it finds gets its rank in
// its cluster's list there and then: its rank within the workgroup's part (the table's count
// before it) plus, once the group has added its totals, the part's start (the cursor before the
// group's add), kept per group and bin; a cluster the table cannot hold (full after
// MYRIAD_ASSIGN_PROBES probes) takes its rank from a global atomic per pair. The pair is recorded
// (light, cluster or bin, rank) in the workgroup's region of the pair buffer, a slot per cluster
// of the light's box (a slot whose cluster the light does not reach holds kNoLight).
//
// Assigning pass (kAssign = true, after the scan, the same number of workgroups): each workgroup
// copies its region's pairs into the lists, nothing walked again.
//
// Lights reaching more than MYRIAD_LARGE_LIGHT_CLUSTERS clusters, and any light whose box no
// longer fits its workgroup's region, are queued for the per-workgroup passes of
// cluster_assign.comp (kLarge), which count them separately (clusterSpill) and fill them after
// the recorded pairs. Counts are exact either way; the order within a list is whatever the atomics
// give, as in cluster_assign.comp.
//
// The pair buffer (pairWords), for G workgroups: G words, each group's count of region slots used;
// G x kBins uvec2 (cluster, start of the group's part), each group's table; then the regions, an
// equal share of the rest per workgroup, each three arrays of regionSize() words (light, cluster
// or bin | kInTable, rank).
#include "frame.glsl"
#include "compute_targets.glsl"
#include "cluster_assign.glsl"
#include "light_orbit.glsl"

layout(local_size_x = MYRIAD_ASSIGN_BIN_GROUP) in;
layout(constant_id = 0) const bool kAssign = false;
layout(constant_id = 2) const uint kBins = MYRIAD_ASSIGN_BINS;  // a power of two
// Counting pass with kAnimate: the frame's lights move here (light_orbit.glsl), each written once
// by the thread that walks it, instead of in light_animate.comp before.
layout(constant_id = 3) const bool kAnimate = false;
// kWalkLarge: the large lights (and those whose region is full) are walked by the workgroup that
// met them, all its invocations side by side, in this pass, and by every workgroup in turn from the
// queue in the assigning pass: no passes of their own (cluster_assign.comp's kLarge).
layout(constant_id = 4) const bool kWalkLarge = false;

layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_ORIGINS) readonly buffer OriginBlock {
  GpuPointLight origins[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) writeonly buffer MovingLightBlock {
  GpuPointLight movingLights[];
};

const uint kGroup = MYRIAD_ASSIGN_BIN_GROUP;
const uint kEmpty = 0xFFFFFFFFu;  // a free bin's cluster
const uint kNoBin = 0xFFFFFFFFu;
const uint kNoLight = 0xFFFFFFFFu;  // a region slot holding no pair
const uint kInTable = 0x80000000u;  // a recorded pair's cluster word is its group's bin

shared uint binCluster[kBins];
shared uint binCount[kBins];  // pairs counted
shared uint regionUsed;        // region slots handed out (may pass the region's size)
shared uint largeCount;        // kWalkLarge: large lights met in this step
shared vec4 largeLight[kGroup];

// Where this workgroup's table and region start, and how many slots a region has (both passes
// run the same number of workgroups).
uint tablesEnd() {
  return gl_NumWorkGroups.x * (1u + 2u * kBins);
}
uint regionSize() {
  return (uint(pairWords.length()) - tablesEnd()) / (3u * gl_NumWorkGroups.x);
}
uint regionStart() {
  return tablesEnd() + gl_WorkGroupID.x * 3u * regionSize();
}
uint tableStart() {
  return gl_NumWorkGroups.x + gl_WorkGroupID.x * kBins * 2u;
}

// The bin holding `cluster`, claiming a free one; kNoBin if the table cannot hold it.
uint claimBin(uint cluster) {
  uint h = (cluster * 2654435761u) >> 16u;
  for (uint p = 0u; p < MYRIAD_ASSIGN_PROBES; ++p) {
    uint bin = (h + p) & (kBins - 1u);
    uint held = atomicCompSwap(binCluster[bin], kEmpty, cluster);
    if (held == cluster || held == kEmpty) return bin;
  }
  return kNoBin;
}

void queueLarge(uint index, vec4 light) {
  uint slot = atomicAdd(largeQueue.queued.x, 1u);
  largeLights[slot] = index;
  if (kWalkLarge) {
    largeLight[atomicAdd(largeCount, 1u)] = light;
  } else {
    // The indirect dispatch's group count: the queue's length, at most the groups it may have.
    atomicMax(largeQueue.groups.x, min(slot + 1u, MYRIAD_LARGE_LIGHT_GROUPS));
  }
}

// kWalkLarge, counting: this invocation's share of a large light's clusters.
void countLargeLight(vec4 light) {
  LightClusters b;
  if (!lightClustersAt(light, b)) return;
  for (uint i = gl_LocalInvocationIndex; i < b.clusters; i += kGroup) {
    uint cluster;
    if (lightReachesCluster(b, i, false, cluster)) atomicAdd(clusterCursors[clusterSpill(cluster)], 1u);
  }
}

// kWalkLarge, assigning: this invocation's share of a queued light's clusters, each pair taking
// the next slot after the recorded ones.
void placeLargeLight(uint index) {
  LightClusters b;
  if (!lightClusters(index, b)) return;
  for (uint i = gl_LocalInvocationIndex; i < b.clusters; i += kGroup) {
    uint cluster;
    if (!lightReachesCluster(b, i, true, cluster)) continue;
    uint slot = atomicAdd(clusterCursors[clusterSpill(cluster)], 1u);
    uvec2 range = clusterRanges[cluster];
    if (slot < range.y) clusterLights[range.x + slot] = index;
  }
}

// Walks light `index`'s clusters once, ranking and recording each pair.
void countLight(uint index, uint size, uint region) {
  if (index >= frame.flags.y) return;
  vec4 light;
  if (kAnimate) {
    light = orbitPosition(index, origins[index].positionRadius, frame.slicing.w);
    movingLights[index].positionRadius = light;
  } else {
    light = lights[index].positionRadius;
  }
  LightClusters b;
  if (!lightClustersAt(light, b)) return;
  if (b.clusters > MYRIAD_LARGE_LIGHT_CLUSTERS) {
    queueLarge(index, light);
    return;
  }
  uint at = atomicAdd(regionUsed, b.clusters);
  if (at + b.clusters > size) {
    // The region is full: the large-light passes take this light; the slots it was handed that
    // lie inside the region hold no pair.
    for (uint s = at; s < size; ++s) pairWords[region + s] = kNoLight;
    queueLarge(index, light);
    return;
  }
  for (uint i = 0u; i < b.clusters; ++i) {
    uint s = region + at + i;
    uint cluster;
    if (!lightReachesCluster(b, i, false, cluster)) {
      pairWords[s] = kNoLight;
      continue;
    }
    uint bin = claimBin(cluster);
    uint code, rank;
    if (bin != kNoBin) {
      rank = atomicAdd(binCount[bin], 1u);
      code = bin | kInTable;
    } else {
      rank = atomicAdd(clusterCursors[cluster], 1u);
      code = cluster;
    }
    pairWords[s] = index;
    pairWords[s + size] = code;
    pairWords[s + 2u * size] = rank;
  }
}

// Copies one recorded pair into its cluster's list (cut at the list's kept length).
void placePair(uint s, uint size, uint table) {
  uint index = pairWords[s];
  if (index == kNoLight) return;
  uint cluster = pairWords[s + size];
  uint rank = pairWords[s + 2u * size];
  if ((cluster & kInTable) != 0u) {
    uint t = table + (cluster & ~kInTable) * 2u;
    cluster = pairWords[t];
    rank += pairWords[t + 1u];
  }
  uvec2 range = clusterRanges[cluster];
  if (rank < range.y) clusterLights[range.x + rank] = index;
}

void main() {
  uint thread = gl_LocalInvocationIndex;
  uint size = regionSize();
  uint region = regionStart();
  if (kAssign) {
    uint used = min(pairWords[gl_WorkGroupID.x], size);
    uint table = tableStart();
    for (uint s = thread; s < used; s += kGroup) placePair(region + s, size, table);
    if (kWalkLarge) {
      for (uint q = gl_WorkGroupID.x; q < largeQueue.queued.x; q += gl_NumWorkGroups.x) {
        placeLargeLight(largeLights[q]);
      }
    }
    return;
  }
  for (uint bin = thread; bin < kBins; bin += kGroup) {
    binCluster[bin] = kEmpty;
    binCount[bin] = 0u;
  }
  if (thread == 0u) {
    regionUsed = 0u;
    largeCount = 0u;
  }
  barrier();
  // This group's lights: a contiguous run of an equal share, kGroup consecutive lights per step
  // (coalesced reads).
  uint lightCount = frame.flags.y;
  uint share = (lightCount + gl_NumWorkGroups.x - 1u) / gl_NumWorkGroups.x;
  uint first = gl_WorkGroupID.x * share;
  uint end = min(first + share, lightCount);
  uint steps = (share + kGroup - 1u) / kGroup;
  for (uint k = 0u; k < steps; ++k) {
    uint index = first + k * kGroup + thread;
    countLight(index < end ? index : lightCount, size, region);
    if (kWalkLarge) {
      // The step's large lights, by the whole group.
      barrier();
      uint n = largeCount;
      barrier();
      if (thread == 0u) largeCount = 0u;
      for (uint j = 0u; j < n; ++j) countLargeLight(largeLight[j]);
      barrier();
    }
  }
  barrier();
  // Each cluster's total once; the cursor before the add is where the group's part starts.
  uint table = tableStart();
  for (uint bin = thread; bin < kBins; bin += kGroup) {
    uint count = binCount[bin];
    if (count == 0u) continue;
    uint cluster = binCluster[bin];
    pairWords[table + bin * 2u] = cluster;
    pairWords[table + bin * 2u + 1u] = atomicAdd(clusterCursors[cluster], count);
  }
  if (thread == 0u) pairWords[gl_WorkGroupID.x] = min(regionUsed, size);
}
