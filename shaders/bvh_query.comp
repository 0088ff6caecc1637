#version 450
#extension GL_GOOGLE_include_directive : require
// Rays given in a buffer traced through the BVH, one invocation each: what the tests compare
// with a brute-force test over every triangle (tests/bvh_tests.cpp), and the rays-per-second
// figure of a BVH with no frame around it. Its layout is the build passes'.
#include "bvh_build.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_RAYS) readonly buffer RayBlock {
  BvhRay rays[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_HITS) writeonly buffer HitBlock {
  uint hits[];
};

#define MYRIAD_BVH_TRACE_DECLARED
#define bvhTriangles triangles
#define bvhNodes nodes
#define bvhHeader header
#include "bvh_trace.glsl"

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.params.x) return;  // params.x: the rays
  BvhRay r = rays[i];
  hits[i] = bvhOccluded(r.originTMin.xyz, r.directionTMax.xyz, r.originTMin.w, r.directionTMax.w) ? 1u : 0u;
}
