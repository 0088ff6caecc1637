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
// points, world space, as two vec4 (lo.xyz, hi.xyz), written by the numbering pass
// (cluster_mark.comp) from the mark passes' per-slot accumulation (cluster_bounds.glsl), widened
// for rounding (lo.w 0), and widened to the cluster's whole view box by the blended surfaces'
// mark pass (lo.w 1; their fragments are not among those points). The overlap test of
// cluster_assign.glsl reads them for active clusters only.
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
// The margin by which the numbering pass widens a cluster's bounds of points (cluster_mark.comp)
// at depth `depth` (beyond the slice's far side), and the view box below: (|coordinate| + 1) x
// (1e-5 + 1e-6 x depth / near) a side.
vec3 boundsMargin(vec3 lo, vec3 hi, float depth) {
  return (max(abs(lo), abs(hi)) + vec3(1.0)) * (1e-5 + 1e-6 * depth / frame.camera.y);
}
// The cluster's bounds become the world box around its view box (frame.glsl's clusterViewBox,
// which holds every point of the cluster; the view matrix is rigid), widened as above: a blended
// surface marked it, and the lights reaching its fragments must be in its list too. `always`: the
// bounds may be another frame's (the caller numbered the cluster), else only bounds the numbering
// pass wrote this frame (lo.w 0) are widened, once (the writes race, all writing the same).
void widenToViewBox(uint cluster, bool always) {
  uint q = clusterBoundsQuad(cluster);
  if (!always && clusterCursorQuads[q].w != 0.0) return;
  uint across = frame.grid.x * frame.grid.y;
  uvec3 at = uvec3(cluster % frame.grid.x, (cluster % across) / frame.grid.x, cluster / across);
  vec3 lo, hi;
  clusterViewBox(at, lo, hi);
  mat3 toWorld = transpose(mat3(frame.view));
  vec3 centre = toWorld * (0.5 * (lo + hi) - frame.view[3].xyz);
  vec3 extent = abs(toWorld[0]) * (0.5 * (hi.x - lo.x)) + abs(toWorld[1]) * (0.5 * (hi.y - lo.y)) +
                abs(toWorld[2]) * (0.5 * (hi.z - lo.z));
  vec3 worldLo = centre - extent, worldHi = centre + extent;
  vec3 margin = boundsMargin(worldLo, worldHi, 1.1 * -lo.z);
  clusterCursorQuads[q] = vec4(worldLo - margin, 1.0);
  clusterCursorQuads[q + 1u] = vec4(worldHi + margin, 0.0);
}

// Marks cluster `cluster` active (cursor 0, nothing counted), numbering it, if no pass marked it
// yet this frame; true for the caller that numbered it. The plain read first: most callers find
// it marked already.
bool markCluster(uint cluster) {
  if (clusterCursors[cluster] == 0u) return false;
  if (atomicCompSwap(clusterCursors[cluster], MYRIAD_CLUSTER_INACTIVE, 0u) != MYRIAD_CLUSTER_INACTIVE) return false;
  clusterCursors[clusterSpill(cluster)] = 0u;
  uint id = atomicAdd(clusterCursors[activeCountWord()], 1u);
  clusterCursors[clusterIdWord(cluster)] = id;
  clusterCursors[activeClusterWord(id)] = cluster;
  return true;
}

#endif
