#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 1b: the clusters that alpha-blended surfaces cover (drawn with the G-buffer's
// depth test, not writing it) get light lists too, so the forward pass (forward_clustered.frag)
// finds every light reaching its fragments, in front of opaque geometry or over the background.
#include "frame.glsl"
#include "cluster_cursors.glsl"

void main() {
  uvec2 tile = uvec2(gl_FragCoord.xy) / clusterTileSize();
  // Active and numbered, as in cluster_mark.comp; its lights not cut to the opaque points'
  // bounds but to its view box (cluster_cursors.glsl): these fragments are not among the points.
  uint cluster = clusterIndex(uvec3(tile, sliceOfViewDepth(viewDepthFromDepth(gl_FragCoord.z))));
  widenToViewBox(cluster, markCluster(cluster));
}
