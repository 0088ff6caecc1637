#version 450
#extension GL_GOOGLE_include_directive : require
// The radix sort's scan (bvh_sort.glsl): the digit-major counts into exclusive offsets, in place,
// in three phases (kPhase) so that every multiprocessor takes part (a million triangles: 125,000
// counts):
//   0  one workgroup per chunk of 4 x MYRIAD_BVH_SCAN_GROUP counts scans it and writes its total
//      after the counts (at MYRIAD_BVH_SORT_BINS x groups, one word a chunk);
//   1  one workgroup scans the chunks' totals, chunk by chunk with a running carry;
//   2  one workgroup per chunk adds its chunk's offset to its counts.
#include "bvh_sort.glsl"

layout(local_size_x = MYRIAD_BVH_SCAN_GROUP) in;
layout(constant_id = 0) const uint kPhase = 0u;

const uint kChunk = 4u * uint(MYRIAD_BVH_SCAN_GROUP);

shared uint sums[MYRIAD_BVH_SCAN_GROUP];

// Exclusive scan of histogram[start, min(start + kChunk, end)) in place, plus `carry`; returns
// the chunk's total. Every invocation of the workgroup calls it (it holds barriers).
uint scanChunk(uint start, uint end, uint carry) {
  uint thread = gl_LocalInvocationID.x;
  uint at = start + 4u * thread;
  uint v[4];
  uint own = 0u;
  for (uint k = 0u; k < 4u; ++k) {
    v[k] = at + k < end ? histogram[at + k] : 0u;
    own += v[k];
  }
  sums[thread] = own;
  barrier();
  // Hillis-Steele inclusive scan of the invocations' sums.
  for (uint offset = 1u; offset < uint(MYRIAD_BVH_SCAN_GROUP); offset <<= 1u) {
    uint add = thread >= offset ? sums[thread - offset] : 0u;
    barrier();
    sums[thread] += add;
    barrier();
  }
  uint running = carry + sums[thread] - own;
  for (uint k = 0u; k < 4u; ++k) {
    if (at + k < end) histogram[at + k] = running;
    running += v[k];
  }
  uint total = sums[MYRIAD_BVH_SCAN_GROUP - 1];
  barrier();  // sums is free again
  return total;
}

void main() {
  uint total = uint(MYRIAD_BVH_SORT_BINS) * sortGroups();
  uint chunks = (total + kChunk - 1u) / kChunk;
  uint group = gl_WorkGroupID.x;
  if (kPhase == 0u) {
    uint chunkTotal = scanChunk(group * kChunk, total, 0u);
    if (gl_LocalInvocationID.x == 0u) histogram[total + group] = chunkTotal;
  } else if (kPhase == 1u) {
    uint carry = 0u;
    for (uint start = total; start < total + chunks; start += kChunk) {
      carry += scanChunk(start, total + chunks, carry);
    }
  } else {
    uint offset = histogram[total + group];
    uint at = group * kChunk + 4u * gl_LocalInvocationID.x;
    for (uint k = 0u; k < 4u; ++k) {
      if (at + k < total) histogram[at + k] += offset;
    }
  }
}
