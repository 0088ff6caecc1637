#version 450
#extension GL_GOOGLE_include_directive : require
// The radix sort's scatter (bvh_sort.glsl): each workgroup moves its keys and values to their
// sorted places, in their order: a key's place is its digit's offset for the group, plus the keys
// of that digit in earlier rounds, plus those of earlier invocations in its round (counted in
// shared memory: stable).
#include "bvh_sort.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

shared uint offsets[MYRIAD_BVH_SORT_BINS];
shared uint roundDigits[MYRIAD_BVH_GROUP];

void main() {
  uint thread = gl_LocalInvocationID.x;
  uint group = gl_WorkGroupID.x;
  for (uint d = thread; d < uint(MYRIAD_BVH_SORT_BINS); d += uint(MYRIAD_BVH_GROUP)) {
    offsets[d] = histogram[d * sortGroups() + group];
  }
  uint n = triangleCount();
  uint base = group * kKeysPerGroup;
  for (uint r = 0u; r < uint(MYRIAD_BVH_SORT_ROUNDS); ++r) {
    uint i = base + r * uint(MYRIAD_BVH_GROUP) + thread;
    bool inside = i < n;
    uint key = inside ? keys[sourceOffset() + i] : 0u;
    uint digit = inside ? digitOf(key) : uint(MYRIAD_BVH_SORT_BINS);  // past every digit
    roundDigits[thread] = digit;
    barrier();
    uint rank = 0u;
    for (uint j = 0u; j < thread; ++j) rank += roundDigits[j] == digit ? 1u : 0u;
    if (inside) {
      uint to = offsets[digit] + rank;
      keys[targetOffset() + to] = key;
      values[targetOffset() + to] = values[sourceOffset() + i];
    }
    barrier();
    if (inside) atomicAdd(offsets[digit], 1u);
    barrier();
  }
}
