// FrameTargets::clusterMarks, written by the passes that mark the clusters
// (visibility_resolve.comp, cluster_mark.comp's pixel pass): a bit per cluster that holds
// geometry, then the world-space bounds of each cluster's surface points, six words per cluster,
// each an atomicMax, so that all-zero (the buffer's state when made and after the numbering pass
// read it) is empty. The hi words hold boundsKey(hi), the lo words ~boundsKey(lo). The numbering
// pass (cluster_mark.comp) turns them into the cluster's bounds for the light assignment
// (cluster_cursors.glsl) and zeroes them. Needs `frame` and the includer's `uint clusterMarks[]`.
#ifndef MYRIAD_CLUSTER_BOUNDS_GLSL
#define MYRIAD_CLUSTER_BOUNDS_GLSL

// Sets cluster `cluster`'s mark bit (it holds geometry). Most pixels find it set and only read.
void markClusterBit(uint cluster) {
  uint bit = 1u << (cluster & 31u);
  if ((clusterMarks[cluster >> 5u] & bit) == 0u) atomicOr(clusterMarks[cluster >> 5u], bit);
}

// A float's bits mapped so that unsigned order is the floats' order; never 0 for a number.
uint boundsKey(float f) {
  uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float boundsValue(uint key) {
  return uintBitsToFloat((key & 0x80000000u) != 0u ? key & 0x7FFFFFFFu : ~key);
}

// The first word of cluster `cluster`'s six (after the mark bits, whole pairs of words).
uint clusterBoundsWord(uint cluster) {
  uint clusters = frame.grid.x * frame.grid.y * frame.grid.z;
  return (clusters + 63u) / 64u * 2u + 6u * cluster;
}

uvec3 boundsKeys(vec3 v) {
  return uvec3(boundsKey(v.x), boundsKey(v.y), boundsKey(v.z));
}

// Adds the box whose words are loWords (~boundsKey(lo)) and hiWords (boundsKey(hi)) to cluster
// `cluster`'s bounds.
void addClusterWords(uint cluster, uvec3 loWords, uvec3 hiWords) {
  uint w = clusterBoundsWord(cluster);
  for (uint a = 0u; a < 3u; ++a) {
    atomicMax(clusterMarks[w + a], loWords[a]);
    atomicMax(clusterMarks[w + 3u + a], hiWords[a]);
  }
}

// Adds the box [lo, hi] to cluster `cluster`'s bounds.
void addClusterBounds(uint cluster, vec3 lo, vec3 hi) {
  addClusterWords(cluster, ~boundsKeys(lo), boundsKeys(hi));
}

#endif
