// The overlap test of clustered steps 2 and 4 (cluster_assign.comp, cluster_assign_binned.comp):
// which clusters a light's sphere reaches: its view box of clusters, then the bounds of each
// active cluster's surface points (kPointTest). Every pass that counts or fills the lists walks a
// light's clusters through these two functions, so counts and lists agree exactly.
#ifndef MYRIAD_CLUSTER_ASSIGN_GLSL
#define MYRIAD_CLUSTER_ASSIGN_GLSL

// Which boxes a light is tested against (techniques/clustered.cpp, --tune point-test, a
// benchmark switch): 2 the bounds of the cluster's points only (they lie in its view box, so the
// view box adds little: H200, a million lights at 1080p, 0.07% more list entries and assign
// 0.007 ms less than testing both), 1 the view box and the points' bounds, 0 the view box only
// (before stop 18). All conservative.
layout(constant_id = 7) const uint kPointTest = 2u;

// A light's view-space sphere and the box of clusters around it.
struct LightClusters {
  vec3 c;         // view-space centre
  float r;        // radius
  vec3 w;         // world-space centre
  uvec3 first;    // tile x, tile y, slice of the box's first cluster
  uvec3 extent;   // clusters across, down, deep
  uint clusters;  // extent.x * extent.y * extent.z
};

// The box of clusters a light at `light` (world position, radius) may reach; false if it is not
// on screen.
bool lightClustersAt(vec4 light, out LightClusters b) {
  b.c = (frame.view * vec4(light.xyz, 1.0)).xyz;
  b.r = light.w;
  b.w = light.xyz;
  b.first = uvec3(0u);
  b.extent = uvec3(0u);
  b.clusters = 0u;
  float zMin = max(-b.c.z - b.r, frame.camera.y);
  float zMax = min(-b.c.z + b.r, frame.camera.z);
  if (zMin > zMax) return false;  // entirely behind the near plane or beyond the far plane

  // Screen bounds of the sphere's view-space box clipped to [zMin, zMax]: x/z is monotonic in x
  // and in z over the box, so its extremes are at the corners. Conservative, never too small.
  vec2 p = vec2(frame.projection[0][0], frame.projection[1][1]);
  vec2 lo = vec2(1e30), hi = vec2(-1e30);
  for (int i = 0; i < 4; ++i) {
    vec2 xy = b.c.xy + vec2((i & 1) == 0 ? -b.r : b.r, (i & 2) == 0 ? -b.r : b.r);
    vec2 n0 = p * xy / zMin, n1 = p * xy / zMax;
    lo = min(lo, min(n0, n1));
    hi = max(hi, max(n0, n1));
  }
  // A jittered projection (TAA's sub-frames) moves every point by -projection[2].xy in NDC.
  lo -= vec2(frame.projection[2][0], frame.projection[2][1]);
  hi -= vec2(frame.projection[2][0], frame.projection[2][1]);
  if (hi.x < -1.0 || hi.y < -1.0 || lo.x > 1.0 || lo.y > 1.0) return false;
  vec2 size = frame.viewport.xy;
  uvec2 t0 = uvec2(clamp((lo * 0.5 + 0.5) * size / float(clusterTileSize()), vec2(0.0), vec2(frame.grid.xy - 1u)));
  uvec2 t1 = uvec2(clamp((hi * 0.5 + 0.5) * size / float(clusterTileSize()), vec2(0.0), vec2(frame.grid.xy - 1u)));
  uint s0 = sliceOfViewDepth(zMin);
  uint s1 = sliceOfViewDepth(zMax);
  b.first = uvec3(t0, s0);
  b.extent = uvec3(t1 - t0 + 1u, s1 - s0 + 1u);
  b.clusters = b.extent.x * b.extent.y * b.extent.z;
  return true;
}

// The same for light `index` where it is now.
bool lightClusters(uint index, out LightClusters b) {
  return lightClustersAt(lights[index].positionRadius, b);
}

// The i-th cluster of the box (tile x, tile y, slice).
uvec3 boxCluster(LightClusters b, uint i) {
  return uvec3(b.first.x + i % b.extent.x, b.first.y + (i / b.extent.x) % b.extent.y,
               b.first.z + i / (b.extent.x * b.extent.y));
}

bool sphereReachesCluster(LightClusters b, uvec3 at) {
  vec3 bmin, bmax;
  clusterViewBox(at, bmin, bmax);
  return sphereOverlapsBox(b.c, b.r, bmin, bmax);
}

// Whether the sphere overlaps the world-space bounds of the active cluster's own surface points
// (cluster_cursors.glsl; its view box where blended surfaces marked it). On a floor seen at a slant a
// cluster's view box is metres deep while its points lie in a thin slab: most lights in the box
// float out of reach of every point (issue 16, stop 18).
bool sphereReachesPoints(LightClusters b, uint cluster) {
  vec3 lo, hi;
  clusterPointBounds(cluster, lo, hi);
  return sphereOverlapsBox(b.w, b.r, lo, hi);
}

// The i-th cluster of the box (i < b.clusters): true, with its index, when the cluster holds
// geometry and the sphere overlaps it. Counting, a cluster with geometry has a cursor; filling
// (after the scan reset the cursors), it has room in the lists: a cluster with geometry whose
// list was cut to nothing is passed over, as it takes no lights either way.
bool lightReachesCluster(LightClusters b, uint i, bool filling, out uint cluster) {
  uvec3 at = boxCluster(b, i);
  cluster = clusterIndex(at);
  if (filling ? clusterRanges[cluster].y == 0u : clusterCursors[cluster] == MYRIAD_CLUSTER_INACTIVE) {
    return false;
  }
  if (kPointTest == 0u) return sphereReachesCluster(b, at);
  if (kPointTest == 2u) return sphereReachesPoints(b, cluster);
  return sphereReachesCluster(b, at) && sphereReachesPoints(b, cluster);
}

// The same counting, for the binned pass: true when the cluster holds geometry and the sphere
// overlaps it, with its index and its number among the active clusters (cluster_cursors.glsl).
// The number is read only for a cluster the sphere reaches (H200, a million lights: assign about
// 1 us less at 1080p and at 4K than reading it first, issue 16 stop 17).
bool lightReachesActiveCluster(LightClusters b, uint i, out uint cluster, out uint id) {
  uvec3 at = boxCluster(b, i);
  cluster = clusterIndex(at);
  id = MYRIAD_CLUSTER_INACTIVE;
  if (kPointTest != 2u && !sphereReachesCluster(b, at)) return false;
  id = clusterCursors[clusterIdWord(cluster)];
  if (kPointTest == 0u) return id != MYRIAD_CLUSTER_INACTIVE;
  // Read side by side with the number; meaningless (and not used) for an inactive cluster.
  vec3 lo, hi;
  clusterPointBounds(cluster, lo, hi);
  return id != MYRIAD_CLUSTER_INACTIVE && sphereOverlapsBox(b.w, b.r, lo, hi);
}

#endif
