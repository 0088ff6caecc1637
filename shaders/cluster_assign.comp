#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered steps 2 and 4: find the clusters each light's sphere overlaps.
// Counting pass (kAssign = false): add 1 to each active cluster's count of pairs not recorded
// (clusterSpill). Assigning pass (kAssign = true, after the prefix sum): write the light's index
// into each cluster's list at the next slot that clusterSpill (reset by the scan) hands out.
// Both passes run the same overlap test, so counts and lists agree exactly.
//
// One thread per light (kLarge = false) walks the clusters of a light whose screen-and-depth box
// holds at most MYRIAD_LARGE_LIGHT_CLUSTERS; a larger light is queued (by the counting pass) and
// walked by a whole workgroup (kLarge = true, an indirect dispatch of one group per queued light,
// at most MYRIAD_LARGE_LIGHT_GROUPS groups looping over the queue), so a light covering half the
// screen does not keep one thread busy while the rest of the GPU waits.
#include "frame.glsl"
#include "compute_targets.glsl"
#include "cluster_assign.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;
layout(constant_id = 0) const bool kAssign = false;
layout(constant_id = 1) const bool kLarge = false;

// Visits clusters first, first + step, ... of the light's box; returns false if the light is
// not on screen. With queueLarge, a light with more clusters than a thread should walk is
// queued for the large pass instead (counting pass) or left to it (assigning pass).
void assign(uint index, uint first, uint step, bool queueLarge) {
  LightClusters b;
  if (!lightClusters(index, b)) return;
  if (queueLarge && b.clusters > MYRIAD_LARGE_LIGHT_CLUSTERS) {
    if (!kAssign) {
      uint slot = atomicAdd(largeQueue.queued.x, 1u);
      largeLights[slot] = index;
      // The indirect dispatch's group count: the queue's length, at most the groups it may have.
      atomicMax(largeQueue.groups.x, min(slot + 1u, MYRIAD_LARGE_LIGHT_GROUPS));
    }
    return;
  }
  for (uint i = first; i < b.clusters; i += step) {
    uint cluster;
    if (!lightReachesCluster(b, i, kAssign, cluster)) continue;
    if (kAssign) {
      // The scan left clusterSpill after the ranks the counting pass handed out (0 if none).
      uint slot = atomicAdd(clusterCursors[clusterSpill(cluster)], 1u);
      uvec2 range = clusterRanges[cluster];
      if (slot < range.y) clusterLights[range.x + slot] = index;
    } else {
      atomicAdd(clusterCursors[clusterSpill(cluster)], 1u);
    }
  }
}

void main() {
  if (kLarge) {
    // Every group walks queued lights group, group + MYRIAD_LARGE_LIGHT_GROUPS, ...: uniform per
    // group. The stride is the most groups the indirect dispatch has (it has fewer only when
    // the queue is shorter, and then each group walks one light), not gl_NumWorkGroups: a split
    // frame dispatches ranges of these groups in submissions of their own (dispatch base).
    for (uint q = gl_WorkGroupID.x; q < largeQueue.queued.x; q += MYRIAD_LARGE_LIGHT_GROUPS) {
      assign(largeLights[q], gl_LocalInvocationID.x, MYRIAD_LIGHTS_PER_GROUP, false);
    }
  } else {
    uint index = gl_GlobalInvocationID.x;
    if (index >= frame.flags.y) return;
    assign(index, 0u, 1u, true);
  }
}
