#version 450
#extension GL_GOOGLE_include_directive : require
// BVH step 2: each triangle's key, the 30-bit Morton code of its centroid in the box the push
// constants give (10 bits an axis; a centroid outside is clamped to it), and its index as value.
#include "bvh_build.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

// 10 bits spread to every third bit.
uint spreadBits(uint x) {
  x = (x | (x << 16u)) & 0x030000FFu;
  x = (x | (x << 8u)) & 0x0300F00Fu;
  x = (x | (x << 4u)) & 0x030C30C3u;
  x = (x | (x << 2u)) & 0x09249249u;
  return x;
}

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= triangleCount()) return;
  BvhTriangle t = triangles[id];
  vec3 middle = (t.v0.xyz + t.v1.xyz + t.v2.xyz) * (1.0 / 3.0);
  vec3 extent = max(push.boundsMax.xyz - push.boundsMin.xyz, vec3(1e-30));
  vec3 unit = clamp((middle - push.boundsMin.xyz) / extent, 0.0, 1.0);
  uvec3 q = uvec3(min(unit * 1024.0, vec3(1023.0)));
  keys[id] = (spreadBits(q.x) << 2u) | (spreadBits(q.y) << 1u) | spreadBits(q.z);
  values[id] = id;
}
