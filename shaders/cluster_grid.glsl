// The cluster grid's arithmetic (render/cluster_grid.h): view depth from a depth value, the
// exponential slices, a cluster's index and a pixel's cluster. Every pass that places a pixel in
// its cluster (the mark passes, the compute G-buffer's resolve, the shading passes) uses these
// same functions, so they agree to the bit. Needs `frame` (scene_set.glsl).
#ifndef MYRIAD_CLUSTER_GRID_GLSL
#define MYRIAD_CLUSTER_GRID_GLSL

// Distance from the eye along the view axis, from a [0,1] depth value (right-handed, zero-to-one).
float viewDepthFromDepth(float depth) {
  float n = frame.camera.y;
  float f = frame.camera.z;
  return n * f / (f - depth * (f - n));
}

// World position of the pixel centre at `pixel` with depth `depth`: how the shading passes find a
// G-buffer pixel's surface point, and the points whose bounds the mark passes gather
// (cluster_bounds.glsl), so those bounds hold exactly the points shaded.
vec3 worldFromDepth(ivec2 pixel, float depth) {
  vec2 ndc = (vec2(pixel) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 p = frame.inverseViewProjection * vec4(ndc, depth, 1.0);
  return p.xyz / p.w;
}

// Exponential depth slices (Olsson et al. 2012): slice k spans near * (far/near)^(k/S) onwards, so
// clusters stay roughly cubic in view space at every distance.
uint sliceOfViewDepth(float z) {
  float s = floor(log(max(z, frame.camera.y)) * frame.slicing.x - frame.slicing.y);
  return uint(clamp(s, 0.0, float(frame.grid.z - 1)));
}

float viewDepthOfSlice(uint k) {
  return exp((float(k) + frame.slicing.y) / frame.slicing.x);
}

// The clusters' screen tiles are this many pixels square (FrameUniforms.written.y).
uint clusterTileSize() {
  return frame.written.y;
}

uint clusterIndex(uvec3 c) {
  return c.x + frame.grid.x * (c.y + frame.grid.y * c.z);
}

uint clusterOfPixel(ivec2 pixel, float depth) {
  uvec2 tile = uvec2(pixel) / clusterTileSize();
  return clusterIndex(uvec3(tile, sliceOfViewDepth(viewDepthFromDepth(depth))));
}

#endif
