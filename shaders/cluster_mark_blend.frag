#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1b: the clusters that alpha-blended surfaces cover (drawn with the G-buffer's
// depth test, not writing it) get light lists too, so the forward pass (forward_clustered.frag)
// finds every light reaching its fragments, in front of opaque geometry or over the background.
#include "frame.glsl"

layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_CURSORS) buffer CursorBlock {
  uint clusterCursors[];
};

void main() {
  uvec2 tile = uvec2(gl_FragCoord.xy) / clusterTileSize();
  // Every writer writes the same 0s (active, nothing counted), as in cluster_mark.comp.
  uint cluster = clusterIndex(uvec3(tile, sliceOfViewDepth(viewDepthFromDepth(gl_FragCoord.z))));
  if (clusterCursors[cluster] != 0u) {
    clusterCursors[cluster] = 0u;
    clusterCursors[frame.grid.x * frame.grid.y * frame.grid.z + cluster] = 0u;  // clusterSpill
  }
}
