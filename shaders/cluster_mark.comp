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

layout(std430, set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_CLUSTER_MARKS) buffer ClusterMarkBlock {
  uint clusterMarks[];
};

const uint kGroupClusters = MYRIAD_PIXEL_GROUP * MYRIAD_PIXEL_GROUP;  // whole words of bits

shared uint groupMarked;
shared uint groupFirst;

void main() {
  if (!kNumber) {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth >= 1.0) return;
    // Most pixels find the bit set and only read.
    uint cluster = clusterOfPixel(pixel, depth);
    uint bit = 1u << (cluster & 31u);
    if ((clusterMarks[cluster >> 5u] & bit) == 0u) atomicOr(clusterMarks[cluster >> 5u], bit);
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
}
