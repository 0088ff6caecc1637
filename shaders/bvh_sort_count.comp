#version 450
#extension GL_GOOGLE_include_directive : require
// The radix sort's count (bvh_sort.glsl): each workgroup's digit counts, digit-major.
#include "bvh_sort.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

shared uint counts[MYRIAD_BVH_SORT_BINS];

void main() {
  uint thread = gl_LocalInvocationID.x;
  uint group = gl_WorkGroupID.x;
  for (uint d = thread; d < uint(MYRIAD_BVH_SORT_BINS); d += uint(MYRIAD_BVH_GROUP)) counts[d] = 0u;
  barrier();
  uint n = triangleCount();
  uint base = group * kKeysPerGroup;
  for (uint r = 0u; r < uint(MYRIAD_BVH_SORT_ROUNDS); ++r) {
    uint i = base + r * uint(MYRIAD_BVH_GROUP) + thread;
    if (i < n) atomicAdd(counts[digitOf(keys[sourceOffset() + i])], 1u);
  }
  barrier();
  for (uint d = thread; d < uint(MYRIAD_BVH_SORT_BINS); d += uint(MYRIAD_BVH_GROUP)) {
    histogram[d * sortGroups() + group] = counts[d];
  }
}
