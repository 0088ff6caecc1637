#version 450
#extension GL_GOOGLE_include_directive : require
// BVH step 5 (and the whole refit): boxes bottom-up. One invocation per leaf writes its
// triangle's box, then climbs: at each parent it merges the box it carries into the parent's
// (atomicMin / atomicMax of order-preserving bits) and counts its arrival; the first child to
// arrive stops, the second reads the merged box back (atomically: never a stale value, whatever
// the device's caches), writes the parent's node and climbs on with it. Each internal node is
// written once, after both children.
#include "bvh_build.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

// Whether the merges are fenced before the arrival is counted, and the arrival before the merged
// box is read back (render/bvh.cpp: GPUs). Off on CPU devices: llvmpipe runs a workgroup's
// invocations in lock-step and its atomics in order, and a memoryBarrierBuffer() in this loop's
// divergent flow made it drop every invocation still climbing (the boxes above stayed empty).
layout(constant_id = 0) const bool kFence = true;

// A float's bits, flipped so that unsigned order is the floats' order.
uint orderedBits(float f) {
  uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float fromOrderedBits(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7FFFFFFFu : ~u);
}

void main() {
  uint n = triangleCount();
  uint k = gl_GlobalInvocationID.x;
  if (k >= n) return;
  uint triangle = values[k];
  BvhTriangle t = triangles[triangle];
  vec3 lo = min(min(t.v0.xyz, t.v1.xyz), t.v2.xyz);
  vec3 hi = max(max(t.v0.xyz, t.v1.xyz), t.v2.xyz);
  uint node = n - 1u + k;
  nodes[node].lo = vec4(lo, uintBitsToFloat(triangle));
  nodes[node].hi = vec4(hi, uintBitsToFloat(MYRIAD_BVH_LEAF));
  if (k == 0u) header.counts = uvec4(n, n - 1u, 0u, 0u);
  uint arrivals = 2u * n - 1u;
  uint maxima = 4u * (n - 1u);
  bool climbing = true;
  while (climbing) {
    uint parent = parents[node];
    if (parent == MYRIAD_BVH_NONE) {
      climbing = false;
    } else {
      uint at = 4u * parent;
      atomicMin(boxBits[at], orderedBits(lo.x));
      atomicMin(boxBits[at + 1u], orderedBits(lo.y));
      atomicMin(boxBits[at + 2u], orderedBits(lo.z));
      atomicMax(boxBits[maxima + at], orderedBits(hi.x));
      atomicMax(boxBits[maxima + at + 1u], orderedBits(hi.y));
      atomicMax(boxBits[maxima + at + 2u], orderedBits(hi.z));
      if (kFence) memoryBarrierBuffer();
      // The first child to arrive stops: its sibling is not done yet.
      climbing = atomicAdd(parents[arrivals + parent], 1u) != 0u;
      if (climbing) {
        if (kFence) memoryBarrierBuffer();
        lo = vec3(fromOrderedBits(atomicMin(boxBits[at], 0xFFFFFFFFu)),
                  fromOrderedBits(atomicMin(boxBits[at + 1u], 0xFFFFFFFFu)),
                  fromOrderedBits(atomicMin(boxBits[at + 2u], 0xFFFFFFFFu)));
        hi = vec3(fromOrderedBits(atomicMax(boxBits[maxima + at], 0u)),
                  fromOrderedBits(atomicMax(boxBits[maxima + at + 1u], 0u)),
                  fromOrderedBits(atomicMax(boxBits[maxima + at + 2u], 0u)));
        nodes[parent].lo.xyz = lo;
        nodes[parent].hi.xyz = hi;
        node = parent;
      }
    }
  }
}
