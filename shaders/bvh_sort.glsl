// The BVH's radix sort (bvh_sort_count.comp, bvh_sort_scan.comp, bvh_sort_scatter.comp): a
// least-significant-digit sort of the Morton codes, 8 bits a pass, stable, so four passes sort
// 32-bit keys. Each workgroup owns a contiguous run of MYRIAD_BVH_GROUP x MYRIAD_BVH_SORT_ROUNDS
// keys: it counts their digits, the counts of all groups are scanned digit-major (every key of
// digit d in group g goes after every key of a smaller digit, and after digit d's keys of groups
// before g), and the group scatters its keys in order, a round of MYRIAD_BVH_GROUP at a time.
#ifndef MYRIAD_BVH_SORT_GLSL
#define MYRIAD_BVH_SORT_GLSL

#include "bvh_build.glsl"

const uint kKeysPerGroup = uint(MYRIAD_BVH_GROUP * MYRIAD_BVH_SORT_ROUNDS);

uint sortGroups() { return push.params.w; }
// Where the pass reads its keys and values (the other half is where it writes them).
uint sourceOffset() { return push.params.z * triangleCount(); }
uint targetOffset() { return (1u - push.params.z) * triangleCount(); }
uint digitOf(uint key) { return (key >> push.params.y) & uint(MYRIAD_BVH_SORT_BINS - 1); }

#endif
