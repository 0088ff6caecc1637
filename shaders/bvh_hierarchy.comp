#version 450
#extension GL_GOOGLE_include_directive : require
// BVH step 4: the hierarchy over the sorted codes (Karras, "Maximizing Parallelism in the
// Construction of BVHs, Octrees, and k-d Trees", HPG 2012), one invocation per internal node, all
// independent. Internal node i covers a range of sorted keys with i at one end: the direction
// is where its neighbour shares the longer prefix, the other end is found by an exponential then a
// binary search, and the split is where the range's common prefix ends. Equal codes are told
// apart by their index (the prefix of i ^ j counts past the key's 32 bits). Nodes 0 .. n - 2 are
// internal (0 the root), n - 1 + k is the leaf of sorted key k. Writes each node's children and
// every node's parent (the bounds pass's arrival counters are zeroed by a fill before it).
#include "bvh_build.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

// The common prefix of sorted keys i and j, in bits; -1 when j is outside.
int commonPrefix(int i, int j) {
  int n = int(triangleCount());
  if (j < 0 || j >= n) return -1;
  uint a = keys[i];
  uint b = keys[j];
  if (a != b) return 31 - findMSB(a ^ b);
  return 32 + 31 - findMSB(uint(i) ^ uint(j));
}

void main() {
  int n = int(triangleCount());
  int i = int(gl_GlobalInvocationID.x);
  if (i >= n - 1) return;
  int d = commonPrefix(i, i + 1) - commonPrefix(i, i - 1) >= 0 ? 1 : -1;
  int shortest = commonPrefix(i, i - d);
  int most = 2;
  while (commonPrefix(i, i + most * d) > shortest) most *= 2;
  int length = 0;
  for (int step = most / 2; step >= 1; step /= 2) {
    if (commonPrefix(i, i + (length + step) * d) > shortest) length += step;
  }
  int j = i + length * d;
  int prefix = commonPrefix(i, j);
  // The split: the last key of the range sharing more than `prefix` bits with i.
  int split = 0;
  int step = length;
  do {
    step = (step + 1) / 2;
    if (commonPrefix(i, i + (split + step) * d) > prefix) split += step;
  } while (step > 1);
  int gamma = i + split * d + min(d, 0);
  uint leafBase = uint(n - 1);
  uint left = min(i, j) == gamma ? leafBase + uint(gamma) : uint(gamma);
  uint right = max(i, j) == gamma + 1 ? leafBase + uint(gamma + 1) : uint(gamma + 1);
  nodes[i].lo.w = uintBitsToFloat(left);
  nodes[i].hi.w = uintBitsToFloat(right);
  parents[left] = uint(i);
  parents[right] = uint(i);
  if (i == 0) parents[0] = MYRIAD_BVH_NONE;
}
