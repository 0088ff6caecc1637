#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1: mark the clusters that hold visible geometry. Only those get light lists, so
// list memory follows what is on screen, not the size of the grid.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

// The group's pixels lie in one screen tile (the tile's size is a multiple of the group's), so
// they mark at most one cluster per slice: the slices they fall in, as bits.
shared uint slices;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint thread = gl_LocalInvocationIndex;
  if (thread == 0u) {
    slices = 0u;
    if (gl_WorkGroupID.xy == uvec2(0u)) {
      // The frame's counters and the large-light queue start empty (no transfer commands first).
      stats.overflow = uvec4(0u);
      stats.totals = uvec4(0u);
      largeQueue.groups = uvec4(0u, 1u, 1u, 0u);
      largeQueue.queued = uvec4(0u);
    }
  }
  barrier();
  if (pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y)) {
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth < 1.0) atomicOr(slices, 1u << sliceOfViewDepth(viewDepthFromDepth(depth)));
  }
  barrier();
  // Cursors are MYRIAD_CLUSTER_INACTIVE here (the last frame's scan left them so); a cluster with
  // geometry gets 0 and nothing counted (clusterSpill). Other groups of the tile write the same
  // 0s, so races are benign; reading first spares the memory system most of the stores.
  if (thread < frame.grid.z && (slices & (1u << thread)) != 0u) {
    uvec2 tile = gl_WorkGroupID.xy * uint(MYRIAD_PIXEL_GROUP) / clusterTileSize();
    uint cluster = clusterIndex(uvec3(tile, thread));
    if (clusterCursors[cluster] != 0u) {
      clusterCursors[cluster] = 0u;
      clusterCursors[clusterSpill(cluster)] = 0u;
    }
  }
}
