#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1: mark the clusters that hold visible geometry. Only those get light lists, so
// list memory follows what is on screen, not the size of the grid.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  if (depth >= 1.0) return;
  // Cursors start at MYRIAD_CLUSTER_INACTIVE; every writer writes the same 0, so races are benign.
  // Most pixels find their cluster marked already: reading first spares the memory system a store
  // per pixel to a few hundred addresses.
  uint cluster = clusterOfPixel(pixel, depth);
  if (clusterCursors[cluster] != 0u) clusterCursors[cluster] = 0u;
}
