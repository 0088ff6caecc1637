#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered steps 2 and 4, one thread per light: find the clusters the light's sphere overlaps.
// Counting pass (kAssign = false): add 1 to each active cluster's count. Assigning pass
// (kAssign = true, after the prefix sum): write the light's index into each cluster's list.
// Both passes run the same overlap test, so counts and lists agree exactly.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;
layout(constant_id = 0) const bool kAssign = false;

void main() {
  uint index = gl_GlobalInvocationID.x;
  if (index >= frame.flags.y) return;
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

  for (uint s = s0; s <= s1; ++s) {
    for (uint y = t0.y; y <= t1.y; ++y) {
      for (uint x = t0.x; x <= t1.x; ++x) {
        uint cluster = clusterIndex(uvec3(x, y, s));
        if (clusterCursors[cluster] == MYRIAD_CLUSTER_INACTIVE) continue;
        vec3 bmin, bmax;
        clusterViewBox(uvec3(x, y, s), bmin, bmax);
        if (!sphereOverlapsBox(c, r, bmin, bmax)) continue;
        uint slot = atomicAdd(clusterCursors[cluster], 1u);
        if (kAssign) {
          uvec2 range = clusterRanges[cluster];
          if (slot < range.y) clusterLights[range.x + slot] = index;
        }
      }
    }
  }
}
