#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered steps 2 and 4: find the clusters each light's sphere overlaps.
// Counting pass (kAssign = false): add 1 to each active cluster's count. Assigning pass
// (kAssign = true, after the prefix sum): write the light's index into each cluster's list.
// Both passes run the same overlap test, so counts and lists agree exactly.
//
// One thread per light (kLarge = false) walks the clusters of a light whose screen-and-depth box
// holds at most MYRIAD_LARGE_LIGHT_CLUSTERS; a larger light is queued (by the counting pass) and
// walked by a whole workgroup (kLarge = true, an indirect dispatch of one group per queued light,
// at most MYRIAD_LARGE_LIGHT_GROUPS groups looping over the queue), so a light covering half the
// screen does not keep one thread busy while the rest of the GPU waits.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;
layout(constant_id = 0) const bool kAssign = false;
layout(constant_id = 1) const bool kLarge = false;

// Visits clusters first, first + step, ... of the light's box; returns false if the light is
// not on screen. With queueLarge, a light with more clusters than a thread should walk is
// queued for the large pass instead (counting pass) or left to it (assigning pass).
void assign(uint index, uint first, uint step, bool queueLarge) {
  vec4 light = lights[index].positionRadius;
  vec3 c = (frame.view * vec4(light.xyz, 1.0)).xyz;
  float r = light.w;
  float zMin = max(-c.z - r, frame.camera.y);
  float zMax = min(-c.z + r, frame.camera.z);
  if (zMin > zMax) return;  // entirely behind the near plane or beyond the far plane

  // Screen bounds of the sphere's view-space box clipped to [zMin, zMax]: x/z is monotonic in x
  // and in z over the box, so its extremes are at the corners. Conservative, never too small.
  vec2 p = vec2(frame.projection[0][0], frame.projection[1][1]);
  vec2 lo = vec2(1e30), hi = vec2(-1e30);
  for (int i = 0; i < 4; ++i) {
    vec2 xy = c.xy + vec2((i & 1) == 0 ? -r : r, (i & 2) == 0 ? -r : r);
    vec2 n0 = p * xy / zMin, n1 = p * xy / zMax;
    lo = min(lo, min(n0, n1));
    hi = max(hi, max(n0, n1));
  }
  if (hi.x < -1.0 || hi.y < -1.0 || lo.x > 1.0 || lo.y > 1.0) return;
  vec2 size = frame.viewport.xy;
  uvec2 t0 = uvec2(clamp((lo * 0.5 + 0.5) * size / MYRIAD_CLUSTER_TILE_SIZE, vec2(0.0), vec2(frame.grid.xy - 1u)));
  uvec2 t1 = uvec2(clamp((hi * 0.5 + 0.5) * size / MYRIAD_CLUSTER_TILE_SIZE, vec2(0.0), vec2(frame.grid.xy - 1u)));
  uint s0 = sliceOfViewDepth(zMin);
  uint s1 = sliceOfViewDepth(zMax);
  uvec3 extent = uvec3(t1 - t0 + 1u, s1 - s0 + 1u);
  uint clusters = extent.x * extent.y * extent.z;

  if (queueLarge && clusters > MYRIAD_LARGE_LIGHT_CLUSTERS) {
    if (!kAssign) {
      uint slot = atomicAdd(largeQueue.queued.x, 1u);
      largeLights[slot] = index;
      // The indirect dispatch's group count: the queue's length, at most the groups it may have.
      atomicMax(largeQueue.groups.x, min(slot + 1u, MYRIAD_LARGE_LIGHT_GROUPS));
    }
    return;
  }

  for (uint i = first; i < clusters; i += step) {
    uvec3 at = uvec3(t0.x + i % extent.x, t0.y + (i / extent.x) % extent.y,
                     s0 + i / (extent.x * extent.y));
    uint cluster = clusterIndex(at);
    if (clusterCursors[cluster] == MYRIAD_CLUSTER_INACTIVE) continue;
    vec3 bmin, bmax;
    clusterViewBox(at, bmin, bmax);
    if (!sphereOverlapsBox(c, r, bmin, bmax)) continue;
    uint slot = atomicAdd(clusterCursors[cluster], 1u);
    if (kAssign) {
      uvec2 range = clusterRanges[cluster];
      if (slot < range.y) clusterLights[range.x + slot] = index;
    }
  }
}

void main() {
  if (kLarge) {
    // Every group walks queued lights group, group + groups, ...: uniform per group.
    for (uint q = gl_WorkGroupID.x; q < largeQueue.queued.x; q += gl_NumWorkGroups.x) {
      assign(largeLights[q], gl_LocalInvocationID.x, MYRIAD_LIGHTS_PER_GROUP, false);
    }
  } else {
    uint index = gl_GlobalInvocationID.x;
    if (index >= frame.flags.y) return;
    assign(index, 0u, 1u, true);
  }
}
