// Shadow rays through the scene's BVH (render/bvh.h): any hit, so the first triangle found
// between the ends ends the walk. The includer defines MYRIAD_BVH_TRACE_SET, the set its
// pipeline layout holds the trace bindings at (render::Bvh::traceSetLayout), and includes
// bvh_types.h's dependencies first.
#ifndef MYRIAD_BVH_TRACE_GLSL
#define MYRIAD_BVH_TRACE_GLSL

#include "bvh_types.h"
#include "ray_triangle.glsl"

#ifndef MYRIAD_BVH_TRACE_DECLARED  // bvh_query.comp has them from the build set
layout(std430, set = MYRIAD_BVH_TRACE_SET, binding = MYRIAD_BVH_BINDING_TRIANGLES) readonly buffer BvhTriangleBlock {
  BvhTriangle bvhTriangles[];
};
layout(std430, set = MYRIAD_BVH_TRACE_SET, binding = MYRIAD_BVH_BINDING_NODES) readonly buffer BvhNodeBlock {
  BvhNode bvhNodes[];
};
layout(std430, set = MYRIAD_BVH_TRACE_SET, binding = MYRIAD_BVH_BINDING_HEADER) readonly buffer BvhHeaderBlock {
  BvhHeader bvhHeader;
};
#endif

// Whether the slab [lo, hi] meets the ray within (tMin, tMax). `inverseDir` 1 / dir with zeros
// replaced by tiny numbers of their sign (bvhInverse), so a ray along a face's plane is no NaN.
bool rayHitsBox(vec3 origin, vec3 inverseDir, vec3 lo, vec3 hi, float tMin, float tMax) {
  vec3 t0 = (lo - origin) * inverseDir;
  vec3 t1 = (hi - origin) * inverseDir;
  vec3 near = min(t0, t1);
  vec3 far = max(t0, t1);
  float enter = max(max(near.x, near.y), max(near.z, tMin));
  float leave = min(min(far.x, far.y), min(far.z, tMax));
  return enter <= leave;
}

vec3 bvhInverse(vec3 dir) {
  const float tiny = 1e-30;
  return vec3(1.0) / vec3(abs(dir.x) > tiny ? dir.x : (dir.x < 0.0 ? -tiny : tiny),
                          abs(dir.y) > tiny ? dir.y : (dir.y < 0.0 ? -tiny : tiny),
                          abs(dir.z) > tiny ? dir.z : (dir.z < 0.0 ? -tiny : tiny));
}

bool bvhLeafOccludes(BvhNode node, vec3 origin, vec3 dir, float tMin, float tMax) {
  BvhTriangle t = bvhTriangles[floatBitsToUint(node.lo.w)];
  if ((floatBitsToUint(t.v0.w) & MYRIAD_BVH_TRIANGLE_CLEAR) != 0u) return false;
  return rayHitsTriangle(origin, dir, t.v0.xyz, t.v1.xyz, t.v2.xyz, tMin, tMax);
}

// Whether any triangle crosses origin + t dir at tMin < t < tMax (dir need not be unit length).
bool bvhOccluded(vec3 origin, vec3 dir, float tMin, float tMax) {
  uint n = bvhHeader.counts.x;
  if (n == 0u) return false;
  vec3 inverseDir = bvhInverse(dir);
  // The box test widens each box by a hair: a triangle lying in a box's face is still met.
  const float slack = 1e-6;
  uint stack[MYRIAD_BVH_STACK];
  uint depth = 0u;
  uint node = 0u;
  for (;;) {
    BvhNode current = bvhNodes[node];
    if (floatBitsToUint(current.hi.w) == MYRIAD_BVH_LEAF) {
      if (bvhLeafOccludes(current, origin, dir, tMin, tMax)) return true;
    } else if (rayHitsBox(origin, inverseDir, current.lo.xyz - slack * (abs(current.lo.xyz) + 1.0),
                          current.hi.xyz + slack * (abs(current.hi.xyz) + 1.0), tMin, tMax)) {
      // Both children: the right one waits on the stack (a full stack drops nothing: it cannot
      // fill, the tree's depth is below MYRIAD_BVH_STACK).
      stack[depth] = floatBitsToUint(current.hi.w);
      depth = min(depth + 1u, uint(MYRIAD_BVH_STACK) - 1u);
      node = floatBitsToUint(current.lo.w);
      continue;
    }
    if (depth == 0u) return false;
    node = stack[--depth];
  }
}

#endif
