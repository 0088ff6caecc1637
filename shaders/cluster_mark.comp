#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1: mark the clusters that hold visible geometry. Only those get light lists, so
// list memory follows what is on screen, not the size of the grid.
//
// A cluster holding geometry has its bit set in FrameTargets::clusterMarks. The compute G-buffer's
// resolve sets them where it ran (it reads every pixel's depth anyway; FrameUniforms.written.z),
// else the pixel pass here (kNumber = false, 8x8 pixels a workgroup) does from the depth target.
// Then the numbering pass (kNumber, a cluster an invocation, 64 a workgroup) makes each marked
// cluster active (cursor 0, nothing counted), numbers it among the active clusters
// (cluster_cursors.glsl) with one global atomic a workgroup, and clears the bits for the next
// frame.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;
layout(constant_id = 0) const bool kNumber = false;
// cluster_assign.glsl's overlap test; 0 (view boxes only, CPU devices' default): no points'
// bounds are gathered or published (techniques/clustered.cpp's pointTest says why).
layout(constant_id = 7) const uint kPointTest = 2u;

// The mark bits, then the clusters' point bounds (cluster_bounds.glsl).
layout(std430, set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_CLUSTER_MARKS) buffer ClusterMarkBlock {
  uint clusterMarks[];
};
#include "cluster_bounds.glsl"

const uint kGroupClusters = MYRIAD_PIXEL_GROUP * MYRIAD_PIXEL_GROUP;  // whole words of bits

shared uint groupMarked;
shared uint groupFirst;
shared uint groupCluster;    // the pixel pass: the lowest cluster among the group's pixels
shared uint groupBounds[6];  // and its points' bounds (cluster_bounds.glsl's words)

// Cluster `cluster`'s bounds for the assignment (cluster_cursors.glsl) from the mark passes'
// words, which are zeroed for the next frame. Widened for rounding: the shading passes find each
// point again from the same depth bits with the same arithmetic, but may round it differently
// (contracted multiply-adds); the reconstruction's relative error grows as depth / near (the
// w row's terms are about 1 / near, its value 1 / depth), so each side moves out by
// (|coordinate| + 1) x (1e-5 + 1e-6 x depth / near), about 16 times that error's roundings
// for the slice's farthest depth (and 10% beyond).
void publishBounds(uint cluster) {
  uint w = clusterBoundsWord(cluster);
  vec3 lo, hi;
  for (uint a = 0u; a < 3u; ++a) {
    lo[a] = boundsValue(~clusterMarks[w + a]);
    hi[a] = boundsValue(clusterMarks[w + 3u + a]);
  }
  for (uint a = 0u; a < 6u; ++a) clusterMarks[w + a] = 0u;
  uint slice = cluster / (frame.grid.x * frame.grid.y);
  vec3 margin = boundsMargin(lo, hi, 1.1 * viewDepthOfSlice(slice + 1u));
  uint q = clusterBoundsQuad(cluster);
  clusterCursorQuads[q] = vec4(lo - margin, 0.0);
  clusterCursorQuads[q + 1u] = vec4(hi + margin, 0.0);
}

void main() {
  if (!kNumber) {
    // The group's 8x8 pixels lie in one screen tile: the points of the lowest cluster among them
    // (most often all) are reduced in shared memory, one group's six atomics; the others add
    // theirs one by one. kPointTest 0 (a constant, so the same for the whole group): the marks
    // alone.
    uint thread = gl_LocalInvocationIndex;
    if (kPointTest != 0u) {
      if (thread == 0u) groupCluster = MYRIAD_CLUSTER_INACTIVE;
      if (thread < 6u) groupBounds[thread] = 0u;
      barrier();
    }
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    bool surface = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
    float depth = surface ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
    surface = surface && depth < 1.0;
    uint cluster = surface ? clusterOfPixel(pixel, depth) : MYRIAD_CLUSTER_INACTIVE;
    if (surface) markClusterBit(cluster);
    if (kPointTest == 0u) return;
    vec3 p = surface ? worldFromDepth(pixel, depth) : vec3(0.0);  // as the shading passes find it
    if (surface) atomicMin(groupCluster, cluster);
    barrier();
    if (surface) {
      if (cluster == groupCluster) {
        for (uint a = 0u; a < 3u; ++a) {
          atomicMax(groupBounds[a], ~boundsKey(p[a]));
          atomicMax(groupBounds[3u + a], boundsKey(p[a]));
        }
      } else {
        addClusterBounds(cluster, p, p);
      }
    }
    barrier();
    if (thread < 6u && groupCluster != MYRIAD_CLUSTER_INACTIVE) {
      atomicMax(clusterMarks[clusterBoundsWord(groupCluster) + thread], groupBounds[thread]);
    }
    return;
  }
  uint thread = gl_LocalInvocationIndex;
  if (gl_WorkGroupID.x == 0u && thread == 0u) {
    // The frame's counters and the large-light queue start empty (no transfer commands first).
    stats.overflow = uvec4(0u);
    stats.totals = uvec4(0u);
    largeQueue.groups = uvec4(0u, 1u, 1u, 0u);
    largeQueue.queued = uvec4(0u);
  }
  if (thread == 0u) groupMarked = 0u;
  barrier();
  // Cursors are MYRIAD_CLUSTER_INACTIVE here (the last frame's scan left them so).
  uint cluster = gl_WorkGroupID.x * kGroupClusters + thread;
  bool marked = cluster < frame.grid.x * frame.grid.y * frame.grid.z &&
                (clusterMarks[cluster >> 5u] & (1u << (cluster & 31u))) != 0u;
  uint local = marked ? atomicAdd(groupMarked, 1u) : 0u;
  barrier();
  // Every bit of the group's words is read: clear them for the next frame.
  if (thread < kGroupClusters / 32u) clusterMarks[gl_WorkGroupID.x * (kGroupClusters / 32u) + thread] = 0u;
  if (thread == 0u && groupMarked > 0u) groupFirst = atomicAdd(clusterCursors[activeCountWord()], groupMarked);
  barrier();
  if (!marked) return;
  uint id = groupFirst + local;
  clusterCursors[cluster] = 0u;
  clusterCursors[clusterSpill(cluster)] = 0u;
  clusterCursors[clusterIdWord(cluster)] = id;
  clusterCursors[activeClusterWord(id)] = cluster;
  if (kPointTest != 0u) publishBounds(cluster);
}
