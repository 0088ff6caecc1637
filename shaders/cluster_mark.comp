#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1: mark the clusters that hold visible geometry. Only those get light lists, so
// list memory follows what is on screen, not the size of the grid.
//
// Per pixel (kFromMarks = false; 8x8 pixels a workgroup): the G-buffer's depth places each pixel
// in its cluster. From the compute G-buffer's marks (kFromMarks; the resolve pass set a bit per
// cluster holding a pixel, FrameTargets::clusterMarks): one invocation per cluster of the grid,
// 64 a workgroup, the pixels already read once by the resolve.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;
layout(constant_id = 0) const bool kFromMarks = false;

layout(std430, set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_CLUSTER_MARKS) readonly buffer ClusterMarkBlock {
  uint clusterMarks[];
};

void main() {
  if (gl_GlobalInvocationID.xy == uvec2(0u)) {
    // The frame's counters and the large-light queue start empty (no transfer commands first).
    stats.overflow = uvec4(0u);
    stats.totals = uvec4(0u);
    largeQueue.groups = uvec4(0u, 1u, 1u, 0u);
    largeQueue.queued = uvec4(0u);
  }
  // Cursors are MYRIAD_CLUSTER_INACTIVE here (the last frame's scan left them so); a cluster with
  // geometry gets 0 and nothing counted, and its number among the active clusters
  // (cluster_cursors.glsl).
  if (kFromMarks) {
    uint cluster = gl_WorkGroupID.x * (MYRIAD_PIXEL_GROUP * MYRIAD_PIXEL_GROUP) + gl_LocalInvocationIndex;
    if (cluster >= frame.grid.x * frame.grid.y * frame.grid.z) return;
    if ((clusterMarks[cluster >> 5u] & (1u << (cluster & 31u))) != 0u) markCluster(cluster);
    return;
  }
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  if (depth >= 1.0) return;
  // Most pixels find their cluster marked already and only read; of those racing to mark it, one
  // wins the compare-and-swap and numbers it.
  markCluster(clusterOfPixel(pixel, depth));
}
