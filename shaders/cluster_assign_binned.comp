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
// in the workgroup's region of the pair buffer, a slot per cluster of the light's box (a slot whose
// cluster the light does not reach holds kNoLight).
//
// The walk (kFlat): the group takes kGroup lights a step; each invocation moves its light and finds
// its box of clusters, a subgroup scan places the boxes' clusters one after another, and the group
// walks that run of (light, cluster) candidates kGroup at a time, each invocation finding its
// candidate's light by a binary search of the run. A light near the camera with 40 clusters is
// then walked by 40 invocations, not one while its subgroup waits, and the slots written side by
// side are consecutive. Without kFlat each invocation walks its own light's clusters in turn.
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
// The pair buffer (pairWords), for G workgroups: G words, each group's count of region slots used;
// G x kBins words, each group's part's start per cluster number; then the regions, an equal share
// of the rest per workgroup, each three arrays of regionSize() words (light, cluster number |
// kInTable or cluster, rank).
//
// The subgroups must be full (gl_NumSubgroups x gl_SubgroupSize = kGroup, as on every device the
// technique picks this pass for); a step's light p is subgroup p / size's invocation p % size.
#include "frame.glsl"
#include "compute_targets.glsl"
#include "cluster_assign.glsl"
#include "light_orbit.glsl"

// The workgroup's size (constant 6): MYRIAD_ASSIGN_BIN_GROUP, or what the technique asks for (a
// benchmark experiment: more invocations a multiprocessor to hide the walk's latencies).
layout(local_size_x = MYRIAD_ASSIGN_BIN_GROUP, local_size_x_id = 6) in;
layout(constant_id = 0) const bool kAssign = false;
layout(constant_id = 2) const uint kBins = MYRIAD_ASSIGN_BINS;
// Counting pass with kAnimate: the frame's lights move here (light_orbit.glsl), each written once
// by the invocation that finds its box, instead of in light_animate.comp before.
layout(constant_id = 3) const bool kAnimate = false;
layout(constant_id = 4) const bool kFlat = true;
layout(constant_id = 5) const uint kMostClusters = MYRIAD_LARGE_LIGHT_CLUSTERS;
// kCompact (kFlat only): the region holds only the pairs found, one after another (a subgroup
// scan places them), not a slot per candidate, so the assigning pass copies only those.
layout(constant_id = 7) const bool kCompact = false;
// kFillTable: the assigning pass first reads, per cluster number, where its group's part of the
// list starts into shared memory (binCount), so that a pair costs one shared read and the list
// write instead of three dependent global reads.
layout(constant_id = 10) const bool kFillTable = false;
// kPrefetch (kFlat only): each step's lights are read during the step before.
layout(constant_id = 11) const bool kPrefetch = false;
// kSubgroupWalk (kFlat, kCompact): each subgroup lays out and walks its own lights' candidates,
// finding a candidate's light by shuffles, with no barrier of the group's between steps.
layout(constant_id = 12) const bool kSubgroupWalk = false;

layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_ORIGINS) readonly buffer OriginBlock {
  GpuPointLight origins[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) writeonly buffer MovingLightBlock {
  GpuPointLight movingLights[];
};

const uint kGroup = gl_WorkGroupSize.x;
const uint kNoLight = 0xFFFFFFFFu;  // a region slot holding no pair
const uint kInTable = 0x80000000u;  // a recorded pair's cluster word is its cluster's number

// Counting: pairs counted per cluster number. Assigning with kFillTable: where the group's part of
// the number's list starts in clusterLights.
shared uint binCount[kBins];
shared uint regionUsed;       // without kFlat: region slots handed out (may pass the region's size)
                              // kCompact: pairs recorded
shared uint regionReserved;   // kSubgroupWalk: candidates handed out (may pass the region's size)
// kFlat: the step's lights by place p: view-space sphere, box (packBox) and the end of its
// candidates in the step's run.
shared vec4 stepSphere[kGroup];
shared uvec2 stepBox[kGroup];
shared uint stepEnd[kGroup];
shared uint subgroupTotal[kGroup / 4u];  // subgroups have 4 invocations or more

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

// Light `index`'s position and radius as stored: its origin with kAnimate, else where it is.
vec4 lightStored(uint index) {
  return kAnimate ? origins[index].positionRadius : lights[index].positionRadius;
}

// Light `index` where it is this frame, from lightStored(index) (moved and written with kAnimate).
vec4 lightNow(uint index, vec4 stored) {
  if (!kAnimate) return stored;
  vec4 light = orbitPosition(index, stored, frame.slicing.w);
  movingLights[index].positionRadius = light;
  return light;
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

// Without kFlat: walks light `index`'s clusters in turn, ranking and recording each pair.
void countLight(uint index, uint size, uint region) {
  if (index >= frame.flags.y) return;
  vec4 light = lightNow(index, lightStored(index));
  LightClusters b;
  if (!lightClustersAt(light, b)) return;
  if (b.clusters > kMostClusters) {
    queueLarge(index);
    return;
  }
  uint at = atomicAdd(regionUsed, b.clusters);
  if (at + b.clusters > size) {
    // The region is full: the large-light passes take this light; the slots it was handed that
    // lie inside the region hold no pair.
    for (uint s = at; s < size; ++s) pairWords[region + s] = kNoLight;
    queueLarge(index);
    return;
  }
  for (uint i = 0u; i < b.clusters; ++i) {
    uint s = region + at + i;
    uint cluster, id;
    if (lightReachesActiveCluster(b, i, cluster, id)) {
      recordPair(s, size, index, cluster, id);
    } else {
      pairWords[s] = kNoLight;
    }
  }
}

// A box of clusters in shared memory: first x | y << 11 | z << 22, extent the same (tiles and
// slices fewer than 2,048 and 1,024).
uvec2 packBox(LightClusters b) {
  return uvec2(b.first.x | (b.first.y << 11u) | (b.first.z << 22u),
               b.extent.x | (b.extent.y << 11u) | (b.extent.z << 22u));
}
uvec3 unpackBox(uint word) {
  return uvec3(word & 0x7FFu, (word >> 11u) & 0x7FFu, word >> 22u);
}

// kFlat: one step of kGroup lights from `base` (indices at or past `end` are none; the invocation's
// own light read already, `stored`), their candidates in slots used, used + 1, ... of the region
// (kCompact: the region's candidates only counted, the pairs found placed from regionUsed on);
// returns the candidates the step had.
uint countStep(uint base, uint end, vec4 stored, uint used, uint size, uint region) {
  uint p = gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID;
  uint index = base + p;
  LightClusters b;
  uint n = 0u;
  if (index < end && lightClustersAt(lightNow(index, stored), b)) {
    if (b.clusters > kMostClusters) {
      queueLarge(index);
    } else {
      n = b.clusters;
    }
  }
  // The run: the step's boxes one after another in the order of p.
  uint inSubgroup = subgroupInclusiveAdd(n);
  if (gl_SubgroupInvocationID == gl_SubgroupSize - 1u) subgroupTotal[gl_SubgroupID] = inSubgroup;
  barrier();
  uint before = 0u, total = 0u;
  for (uint g = 0u; g < gl_NumSubgroups; ++g) {
    uint t = subgroupTotal[g];
    if (g < gl_SubgroupID) before += t;
    total += t;
  }
  uint runEnd = before + inSubgroup;
  stepEnd[p] = runEnd;
  if (n > 0u) {
    stepSphere[p] = vec4(b.c, b.r);
    stepBox[p] = packBox(b);
    // A box past the region's end: the large-light passes take the light (its slots inside the
    // region hold no pair, below).
    if (used + runEnd > size) queueLarge(index);
  }
  barrier();
  uint light = 0u;
  // Every invocation takes every round (kCompact's subgroup scan wants them all).
  for (uint round = 0u; round < total; round += kGroup) {
    uint j = round + gl_LocalInvocationIndex;
    uint slot = used + j;
    bool found = false;
    uint cluster, id;
    if (j < total) {
      // The candidate's light: the first place whose run ends after j (at or after the last found).
      uint hi = kGroup - 1u;
      while (light < hi) {
        uint mid = (light + hi) >> 1u;
        if (stepEnd[mid] > j) {
          hi = mid;
        } else {
          light = mid + 1u;
        }
      }
      uint lightEnd = stepEnd[light];
      if (used + lightEnd <= size) {
        uvec2 box = stepBox[light];
        vec4 sphere = stepSphere[light];
        LightClusters c;
        c.c = sphere.xyz;
        c.r = sphere.w;
        c.first = unpackBox(box.x);
        c.extent = unpackBox(box.y);
        c.clusters = c.extent.x * c.extent.y * c.extent.z;
        found = lightReachesActiveCluster(c, j - (lightEnd - c.clusters), cluster, id);
      }
      if (!kCompact) {
        if (found) {
          recordPair(region + slot, size, base + light, cluster, id);
        } else if (slot < size) {
          pairWords[region + slot] = kNoLight;
        }
      }
    }
    if (kCompact) {
      // The pairs found this round, one after another from the group's count.
      uint one = found ? 1u : 0u;
      uint rank = subgroupExclusiveAdd(one);
      uint count = subgroupAdd(one);
      uint start = 0u;
      if (subgroupElect() && count > 0u) start = atomicAdd(regionUsed, count);
      start = subgroupBroadcastFirst(start);
      if (found) recordPair(region + start + rank, size, base + light, cluster, id);
    }
  }
  barrier();  // the step's shared arrays are read before the next step writes them
  return total;
}

// kSubgroupWalk: the subgroup's lights from `base` (indices at or past `end` are none; the
// invocation's own light read already, `stored`): each reserves its box's candidates in the region
// (a box past its end goes to the large-light passes), and the subgroup walks the candidates
// gl_SubgroupSize at a time, recording the pairs found one after another from regionUsed.
void countSubgroupStep(uint base, uint end, vec4 stored, uint size, uint region) {
  uint lane = gl_SubgroupInvocationID;
  uint index = base + lane;
  LightClusters b;
  uint n = 0u;
  if (index < end && lightClustersAt(lightNow(index, stored), b)) {
    if (b.clusters > kMostClusters) {
      queueLarge(index);
    } else {
      n = b.clusters;
    }
  }
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
    // The candidate's light: the lanes whose runs end at or before j come first.
    uint owner = 0u;
    for (uint step = gl_SubgroupSize >> 1u; step > 0u; step >>= 1u) {
      if (subgroupShuffle(runEnd, owner + step - 1u) <= j) owner += step;
    }
    uint ownerEnd = subgroupShuffle(runEnd, owner);
    bool ownerFits = subgroupShuffle(fits, owner);
    LightClusters c;
    c.c = subgroupShuffle(sphere.xyz, owner);
    c.r = subgroupShuffle(sphere.w, owner);
    uvec2 ownerBox = subgroupShuffle(box, owner);
    c.first = unpackBox(ownerBox.x);
    c.extent = unpackBox(ownerBox.y);
    c.clusters = c.extent.x * c.extent.y * c.extent.z;
    uint cluster, id;
    bool found = j < total && ownerFits &&
                 lightReachesActiveCluster(c, j - (ownerEnd - c.clusters), cluster, id);
    uint one = found ? 1u : 0u;
    uint rank = subgroupExclusiveAdd(one);
    uint count = subgroupAdd(one);
    uint start = 0u;
    if (subgroupElect() && count > 0u) start = atomicAdd(regionUsed, count);
    start = subgroupBroadcastFirst(start);
    if (found) recordPair(region + start + rank, size, base + owner, cluster, id);
  }
}

// Copies one recorded pair into its cluster's list (cut at the list's kept length); `whole`: no
// list was cut this frame, and binCount holds where the group's part of each number's list starts.
void placePair(uint s, uint size, uint table, bool whole) {
  uint index = pairWords[s];
  if (index == kNoLight) return;
  uint cluster = pairWords[s + size];
  uint rank = pairWords[s + 2u * size];
  if ((cluster & kInTable) != 0u) {
    uint id = cluster & ~kInTable;
    if (whole) {
      clusterLights[binCount[id] + rank] = index;
      return;
    }
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
    // The scan counted the active clusters (the numbers in use) and the pairs its cuts dropped.
    bool whole = kFillTable && stats.overflow.z == 0u;
    if (whole) {
      uint numbers = min(stats.totals.y, kBins);
      // A number this group found no pair for holds an old start, which no pair reads.
      for (uint id = thread; id < numbers; id += kGroup) {
        binCount[id] = clusterRanges[clusterCursors[activeClusterWord(id)]].x + pairWords[table + id];
      }
      barrier();
    }
    for (uint s = thread; s < used; s += kGroup) placePair(region + s, size, table, whole);
    return;
  }
  // The table's numbers in use this frame.
  uint numbers = min(clusterCursors[activeCountWord()], kBins);
  for (uint id = thread; id < numbers; id += kGroup) binCount[id] = 0u;
  if (thread == 0u) {
    regionUsed = 0u;
    regionReserved = 0u;
  }
  barrier();
  // This group's lights: a contiguous run of an equal share, kGroup consecutive lights per step
  // (coalesced reads).
  uint lightCount = frame.flags.y;
  uint share = (lightCount + gl_NumWorkGroups.x - 1u) / gl_NumWorkGroups.x;
  uint first = gl_WorkGroupID.x * share;
  uint end = min(first + share, lightCount);
  uint steps = (share + kGroup - 1u) / kGroup;
  uint used = 0u;
  if (kSubgroupWalk) {
    // The group's share split evenly among its subgroups, each taking gl_SubgroupSize
    // consecutive lights a step, the next step's read during the step (kPrefetch).
    uint lights = end > first ? end - first : 0u;
    uint subShare = (lights + gl_NumSubgroups - 1u) / gl_NumSubgroups;
    uint subFirst = first + gl_SubgroupID * subShare;
    uint subEnd = min(subFirst + subShare, end);
    uint lane = gl_SubgroupInvocationID;
    vec4 stored = vec4(0.0);
    if (kPrefetch && subFirst + lane < subEnd) stored = lightStored(subFirst + lane);
    for (uint base = subFirst; base < subEnd; base += gl_SubgroupSize) {
      uint index = base + lane;
      vec4 light = stored;
      if (!kPrefetch && index < subEnd) light = lightStored(index);
      if (kPrefetch && index + gl_SubgroupSize < subEnd) stored = lightStored(index + gl_SubgroupSize);
      countSubgroupStep(base, subEnd, light, size, region);
    }
    steps = 0u;
  }
  // kFlat: a step's light p is subgroup p / size's invocation p % size.
  uint p = gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID;
  vec4 stored = vec4(0.0);
  if (kFlat && kPrefetch && first + p < end) stored = lightStored(first + p);
  for (uint k = 0u; k < steps; ++k) {
    uint base = first + k * kGroup;
    if (kFlat) {
      uint index = base + p;
      vec4 light = stored;
      if (!kPrefetch && index < end) light = lightStored(index);
      // With kPrefetch the next step's light is read now and waited for only then.
      if (kPrefetch && index + kGroup < end) stored = lightStored(index + kGroup);
      used += countStep(base, end, light, used, size, region);
    } else {
      uint index = base + thread;
      countLight(index < end ? index : lightCount, size, region);
    }
  }
  barrier();
  // Each cluster's total once; the cursor before the add is where the group's part starts.
  for (uint id = thread; id < numbers; id += kGroup) {
    uint count = binCount[id];
    if (count == 0u) continue;
    uint cluster = clusterCursors[activeClusterWord(id)];
    pairWords[table + id] = atomicAdd(clusterCursors[cluster], count);
  }
  if (thread == 0u) pairWords[gl_WorkGroupID.x] = min(kFlat && !kCompact && !kSubgroupWalk ? used : regionUsed, size);
}
