#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// The tile pass of the G-buffer rasterised in compute: the triangles the visibility pass queued
// (too large for one thread), one workgroup per (screen tile, queued triangle), an indirect
// dispatch of (tiles across, tiles down, queued). Groups whose tile misses the triangle's box
// return at once; the others test their tile's pixel centres, 4x4 per thread.
#define MYRIAD_VISIBILITY_WRITES_KEYS
#include "visibility.glsl"

layout(local_size_x = MYRIAD_VISIBILITY_TILE_THREADS, local_size_y = MYRIAD_VISIBILITY_TILE_THREADS) in;

layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_LARGE) readonly buffer LargeBlock {
  VisibilityLargeHeader largeHeader;
  VisibilityTriangle largeTriangles[];
};

void main() {
  VisibilityTriangle q = largeTriangles[gl_WorkGroupID.z];
  ivec4 box = ivec4(q.pixels);
  ivec2 tile = ivec2(gl_WorkGroupID.xy) * MYRIAD_VISIBILITY_TILE;
  ivec2 lo = max(box.xy, tile);
  ivec2 hi = min(box.zw, tile + MYRIAD_VISIBILITY_TILE - 1);
  if (any(greaterThan(lo, hi))) return;
  SetupTriangle t = unpackTriangle(q);
  const int steps = MYRIAD_VISIBILITY_TILE / MYRIAD_VISIBILITY_TILE_THREADS;
  for (int j = 0; j < steps; ++j) {
    for (int i = 0; i < steps; ++i) {
      ivec2 pixel = tile + ivec2(i, j) * MYRIAD_VISIBILITY_TILE_THREADS + ivec2(gl_LocalInvocationID.xy);
      if (all(greaterThanEqual(pixel, lo)) && all(lessThanEqual(pixel, hi))) coverPixel(t, pixel);
    }
  }
}
