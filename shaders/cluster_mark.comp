#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1: mark the clusters that hold visible geometry. Only those get light lists, so
// list memory follows what is on screen, not the size of the grid.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel == ivec2(0)) {
    // The frame's counters and the large-light queue start empty (no transfer commands first).
    stats.overflow = uvec4(0u);
    stats.totals = uvec4(0u);
    largeQueue.groups = uvec4(0u, 1u, 1u, 0u);
    largeQueue.queued = uvec4(0u);
  }
  if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  if (depth >= 1.0) return;
  // Cursors are MYRIAD_CLUSTER_INACTIVE here (the last frame's scan left them so); a cluster with
  // geometry gets 0 and nothing counted, and its number among the active clusters
  // (cluster_cursors.glsl). Most pixels find their cluster marked already and only read; of those
  // racing to mark it, one wins the compare-and-swap and numbers it.
  markCluster(clusterOfPixel(pixel, depth));
}
