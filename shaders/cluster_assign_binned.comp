#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
// Clustered steps 2 and 4 for the small lights: each light's clusters are walked once a frame.
//
// Counting pass (kAssign = false; with kAnimate it moves the lights first, see below). A workgroup
// takes a contiguous run of lights and counts its light-cluster pairs per cluster in shared memory,
// a table indexed by the cluster's number among the frame's active clusters (the mark passes
// number them, cluster_cursors.glsl; numbers from kBins on take a global atomic per pair), then
// adds each cluster's total to the cluster's global cursor once, so that a million lights do not
// serialise on the busiest clusters' atomics. Every pair it finds gets its rank in its cluster's
// list there and then: its rank within the workgroup's part (the table's count before it) plus,
// once the group has added its totals, the part's start (the cursor before the group's add), kept
// per group and number. The pair is recorded (light, cluster number | kInTable or cluster, rank)
// in the workgroup's region of the pair buffer, the group's pairs one after another.
//
// The walk: the group's lights are split evenly among its subgroups, and each subgroup takes
// gl_SubgroupSize of its lights a step: each invocation moves its light and finds its box of
// clusters, a subgroup scan lays the boxes' clusters end to end, and the subgroup walks that run
// of (light, cluster) candidates gl_SubgroupSize at a time, each invocation finding its
// candidate's light by a binary search over the lanes' run ends (shuffles). A light near the
// camera with 40 clusters is then walked by 40 invocations, not one while its subgroup waits; the
// subgroups never wait for each other (no barrier between the table's clearing and its flush),
// and the workgroups are as large as the device allows (1,024 invocations), one a
// multiprocessor: both passes wait on memory most of the time, and on the H200 a group of 256 left
// each SM 8 warps to hide that with (issue 16, stop 17: count 0.137 -> 0.068 ms, fill 0.090 ->
// 0.039 with a million lights at 1080p; docs/performance.md).
//
// Assigning pass (kAssign = true, after the scan, the same number of workgroups): each workgroup
// copies its region's pairs into the lists, nothing walked again.
//
// Lights reaching more than kMostClusters clusters, and any light whose box no longer fits its
// workgroup's region, are queued for the per-workgroup passes of cluster_assign.comp (kLarge),
// which count them separately (clusterSpill) and fill them after the recorded pairs. Counts are
// exact either way; the order within a list is whatever the atomics give, as in
// cluster_assign.comp.
//
// The pair buffer (pairWords), for G workgroups: G words, each group's count of recorded pairs;
// G x kBins words, each group's part's start per cluster number; then the regions, an equal share
// of the rest per workgroup, each three arrays of regionSize() words (light, cluster number |
// kInTable or cluster, rank). A region is reserved a slot per candidate (cluster of a light's box,
// reached or not), so a light whose box fits has room for its pairs.
//
// The subgroups must be full (gl_NumSubgroups x gl_SubgroupSize = the group's size, as on every
// device the technique picks this pass for).
#include "frame.glsl"
#include "compute_targets.glsl"
#include "cluster_assign.glsl"
#include "light_orbit.glsl"

// The workgroup's size (constant 6) is the technique's choice (techniques/clustered.cpp).
layout(local_size_x = MYRIAD_ASSIGN_BIN_GROUP, local_size_x_id = 6) in;
layout(constant_id = 0) const bool kAssign = false;
layout(constant_id = 2) const uint kBins = MYRIAD_ASSIGN_BINS;
// Counting pass with kAnimate: the frame's lights move here (light_orbit.glsl), each written once
// by the invocation that finds its box, instead of in light_animate.comp before.
layout(constant_id = 3) const bool kAnimate = false;
layout(constant_id = 5) const uint kMostClusters = MYRIAD_LARGE_LIGHT_CLUSTERS;

layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_ORIGINS) readonly buffer OriginBlock {
  GpuPointLight origins[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) writeonly buffer MovingLightBlock {
  GpuPointLight movingLights[];
};

const uint kGroup = gl_WorkGroupSize.x;
const uint kInTable = 0x80000000u;  // a recorded pair's cluster word is its cluster's number

shared uint binCount[kBins];  // pairs counted per cluster number
shared uint regionReserved;   // candidates the subgroups reserved (may pass the region's size)
shared uint regionUsed;       // pairs recorded

// Where this workgroup's table and region start, and how many slots a region has (both passes
// run the same number of workgroups).
uint tablesEnd() {
  return gl_NumWorkGroups.x * (1u + kBins);
}
uint regionSize() {
  return (uint(pairWords.length()) - tablesEnd()) / (3u * gl_NumWorkGroups.x);
}
uint regionStart() {
  return tablesEnd() + gl_WorkGroupID.x * 3u * regionSize();
}
uint tableStart() {
  return gl_NumWorkGroups.x + gl_WorkGroupID.x * kBins;
}

void queueLarge(uint index) {
  uint slot = atomicAdd(largeQueue.queued.x, 1u);
  largeLights[slot] = index;
  // The indirect dispatch's group count: the queue's length, at most the groups it may have.
  atomicMax(largeQueue.groups.x, min(slot + 1u, MYRIAD_LARGE_LIGHT_GROUPS));
}

// Light `index` where it is this frame (moved and written with kAnimate).
vec4 lightNow(uint index) {
  if (!kAnimate) return lights[index].positionRadius;
  vec4 light = orbitPosition(index, origins[index].positionRadius, frame.slicing.w);
  movingLights[index].positionRadius = light;
  return light;
}

// A box of clusters in a shuffle: first x | y << 11 | z << 22, extent the same (tiles and slices
// fewer than 2,048 and 1,024).
uvec2 packBox(LightClusters b) {
  return uvec2(b.first.x | (b.first.y << 11u) | (b.first.z << 22u),
               b.extent.x | (b.extent.y << 11u) | (b.extent.z << 22u));
}
uvec3 unpackBox(uint word) {
  return uvec3(word & 0x7FFu, (word >> 11u) & 0x7FFu, word >> 22u);
}

// Ranks the pair of light `index` and cluster `cluster` (number `id`) and records it in slot `s`.
void recordPair(uint s, uint size, uint index, uint cluster, uint id) {
  uint code, rank;
  if (id < kBins) {
    rank = atomicAdd(binCount[id], 1u);
    code = id | kInTable;
  } else {
    rank = atomicAdd(clusterCursors[cluster], 1u);
    code = cluster;
  }
  pairWords[s] = index;
  pairWords[s + size] = code;
  pairWords[s + 2u * size] = rank;
}

// One step of the subgroup's lights from `base` (indices at or past `end` are none): each
// reserves its box's candidates in the region (a box past its end goes to the large-light
// passes), and the subgroup walks the candidates gl_SubgroupSize at a time, recording the pairs
// found one after another.
void countStep(uint base, uint end, uint size, uint region) {
  uint lane = gl_SubgroupInvocationID;
  uint index = base + lane;
  // A lane without a light holds an empty box, which no candidate's search lands on.
  LightClusters b = LightClusters(vec3(0.0), 0.0, vec3(0.0), uvec3(0u), uvec3(0u), 0u);
  uint n = 0u;
  if (index < end && lightClustersAt(lightNow(index), b)) {
    if (b.clusters > kMostClusters) {
      queueLarge(index);
    } else {
      n = b.clusters;
    }
  }
  // The run: the lanes' boxes one after another.
  uint runEnd = subgroupInclusiveAdd(n);
  uint total = subgroupMax(runEnd);
  if (total == 0u) return;
  uint reserved = 0u;
  if (subgroupElect()) reserved = atomicAdd(regionReserved, total);
  reserved = subgroupBroadcastFirst(reserved);
  bool fits = reserved + runEnd <= size;
  if (n > 0u && !fits) queueLarge(index);
  vec4 sphere = vec4(b.c, b.r);
  uvec2 box = packBox(b);
  for (uint round = 0u; round < total; round += gl_SubgroupSize) {
    uint j = round + lane;
    // The candidate's light: the lanes whose runs end at or before j come before it.
    uint owner = 0u;
    for (uint step = gl_SubgroupSize >> 1u; step > 0u; step >>= 1u) {
      if (subgroupShuffle(runEnd, owner + step - 1u) <= j) owner += step;
    }
    uint ownerEnd = subgroupShuffle(runEnd, owner);
    bool ownerFits = subgroupShuffle(fits, owner);
    LightClusters c;
    c.c = subgroupShuffle(sphere.xyz, owner);
    c.r = subgroupShuffle(sphere.w, owner);
    c.w = subgroupShuffle(b.w, owner);
    uvec2 ownerBox = subgroupShuffle(box, owner);
    c.first = unpackBox(ownerBox.x);
    c.extent = unpackBox(ownerBox.y);
    c.clusters = c.extent.x * c.extent.y * c.extent.z;
    uint cluster, id;
    bool found = j < total && ownerFits &&
                 lightReachesActiveCluster(c, j - (ownerEnd - c.clusters), cluster, id);
    // The pairs found this round take the next slots of the region, in lane order.
    uint one = found ? 1u : 0u;
    uint before = subgroupExclusiveAdd(one);
    uint count = subgroupAdd(one);
    uint start = 0u;
    if (subgroupElect() && count > 0u) start = atomicAdd(regionUsed, count);
    start = subgroupBroadcastFirst(start);
    if (found) recordPair(region + start + before, size, base + owner, cluster, id);
  }
}

// Copies one recorded pair into its cluster's list (cut at the list's kept length).
void placePair(uint s, uint size, uint table) {
  uint index = pairWords[s];
  uint cluster = pairWords[s + size];
  uint rank = pairWords[s + 2u * size];
  if ((cluster & kInTable) != 0u) {
    uint id = cluster & ~kInTable;
    cluster = clusterCursors[activeClusterWord(id)];
    rank += pairWords[table + id];
  }
  uvec2 range = clusterRanges[cluster];
  if (rank < range.y) clusterLights[range.x + rank] = index;
}

void main() {
  uint thread = gl_LocalInvocationIndex;
  uint size = regionSize();
  uint region = regionStart();
  uint table = tableStart();
  if (kAssign) {
    uint used = min(pairWords[gl_WorkGroupID.x], size);
    for (uint s = thread; s < used; s += kGroup) placePair(region + s, size, table);
    return;
  }
  // The table's numbers in use this frame.
  uint numbers = min(clusterCursors[activeCountWord()], kBins);
  for (uint id = thread; id < numbers; id += kGroup) binCount[id] = 0u;
  if (thread == 0u) {
    regionReserved = 0u;
    regionUsed = 0u;
  }
  barrier();
  // This group's lights: a contiguous run of an equal share, split evenly among its subgroups,
  // each taking gl_SubgroupSize consecutive lights a step (coalesced reads).
  uint lightCount = frame.flags.y;
  uint share = (lightCount + gl_NumWorkGroups.x - 1u) / gl_NumWorkGroups.x;
  uint first = gl_WorkGroupID.x * share;
  uint end = min(first + share, lightCount);
  uint subgroupShare = ((end > first ? end - first : 0u) + gl_NumSubgroups - 1u) / gl_NumSubgroups;
  uint subgroupFirst = first + gl_SubgroupID * subgroupShare;
  uint subgroupEnd = min(subgroupFirst + subgroupShare, end);
  for (uint base = subgroupFirst; base < subgroupEnd; base += gl_SubgroupSize) {
    countStep(base, subgroupEnd, size, region);
  }
  barrier();
  // Each cluster's total once; the cursor before the add is where the group's part starts.
  for (uint id = thread; id < numbers; id += kGroup) {
    uint count = binCount[id];
    if (count == 0u) continue;
    uint cluster = clusterCursors[activeClusterWord(id)];
    pairWords[table + id] = atomicAdd(clusterCursors[cluster], count);
  }
  if (thread == 0u) pairWords[gl_WorkGroupID.x] = min(regionUsed, size);
}
