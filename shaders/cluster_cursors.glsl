// The clustered technique's per-cluster counters (MYRIAD_BINDING_CLUSTER_CURSORS), shared by the
// compute passes (compute_targets.glsl) and the blended surfaces' mark pass
// (cluster_mark_blend.frag).
#ifndef MYRIAD_CLUSTER_CURSORS_GLSL
#define MYRIAD_CLUSTER_CURSORS_GLSL

layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_CURSORS) buffer CursorBlock {
  // Per cluster: MYRIAD_CLUSTER_INACTIVE, or the pairs recorded by the counting pass (each took
  // its rank from here), then the fill cursor of the pairs not recorded. After the grid's
  // clusters, a second count per cluster: the pairs not recorded (clusterSpill); then the active
  // clusters' numbering (clusterIdWord, activeClusterWord, activeCountWord).
  uint clusterCursors[];
};
// Where cluster `cluster`'s count of pairs not recorded lives in clusterCursors.
uint clusterSpill(uint cluster) {
  return frame.grid.x * frame.grid.y * frame.grid.z + cluster;
}
// After the counts of pairs not recorded: the active clusters numbered 0, 1, ... in the order the
// mark passes met them. clusterIdWord(cluster) holds a cluster's number (MYRIAD_CLUSTER_INACTIVE
// when it holds no geometry), activeClusterWord(id) the cluster numbered id, activeCountWord() how
// many there are. The binned counting pass (cluster_assign_binned.comp) indexes its shared table
// by the number, so it needs no hashing; the scan resets numbers and count for the next frame.
uint clusterIdWord(uint cluster) {
  return 2u * frame.grid.x * frame.grid.y * frame.grid.z + cluster;
}
uint activeClusterWord(uint id) {
  return 3u * frame.grid.x * frame.grid.y * frame.grid.z + id;
}
uint activeCountWord() {
  return 4u * frame.grid.x * frame.grid.y * frame.grid.z;
}
// After the count (word 4N) and three words of padding: each cluster's bounds of its surface
// points, world space, as two vec4 (lo.xyz, hi.xyz; w unused), written by the numbering pass
// (cluster_mark.comp) from the mark passes' per-slot accumulation (cluster_bounds.glsl), widened
// for rounding, and made infinite by the blended surfaces' mark pass (their fragments are not
// in them). The overlap test of cluster_assign.glsl reads them for active clusters only.
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_CURSORS) buffer CursorBoundsBlock {
  vec4 clusterCursorQuads[];
};
uint clusterBoundsQuad(uint cluster) {
  return frame.grid.x * frame.grid.y * frame.grid.z + 1u + 2u * cluster;
}
// Cluster `cluster`'s points lie in [lo, hi] (active clusters only).
void clusterPointBounds(uint cluster, out vec3 lo, out vec3 hi) {
  uint q = clusterBoundsQuad(cluster);
  lo = clusterCursorQuads[q].xyz;
  hi = clusterCursorQuads[q + 1u].xyz;
}
// The cluster takes every light its view box takes (a blended surface marked it).
void unboundCluster(uint cluster) {
  uint q = clusterBoundsQuad(cluster);
  float inf = uintBitsToFloat(0x7F800000u);
  if (clusterCursorQuads[q + 1u].x == inf) return;
  clusterCursorQuads[q] = vec4(-inf);
  clusterCursorQuads[q + 1u] = vec4(inf);
}

// Marks cluster `cluster` active (cursor 0, nothing counted), numbering it, if no pass marked it
// yet this frame. The plain read first: most callers find it marked already.
void markCluster(uint cluster) {
  if (clusterCursors[cluster] == 0u) return;
  if (atomicCompSwap(clusterCursors[cluster], MYRIAD_CLUSTER_INACTIVE, 0u) != MYRIAD_CLUSTER_INACTIVE) return;
  clusterCursors[clusterSpill(cluster)] = 0u;
  uint id = atomicAdd(clusterCursors[activeCountWord()], 1u);
  clusterCursors[clusterIdWord(cluster)] = id;
  clusterCursors[activeClusterWord(id)] = cluster;
}

#endif
