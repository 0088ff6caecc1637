// The G-buffer rasterised in compute (render/visibility.h, docs/ARCHITECTURE.md): set 1's
// buffers, a triangle fetched by its id, and the coverage test the visibility and tile passes
// share. A pixel's key is (depth bits << 32) | triangle id: depth >= 0, so its float bits order
// as the depths do, and one 64-bit atomicMin keeps the nearest triangle (the lower id, i.e. the
// one the raster path draws first, on a tie, as its LESS depth test does).
// The including shader enables GL_EXT_shader_explicit_arithmetic_types_int64 (and
// GL_EXT_shader_atomic_int64 where it writes keys) before including this.
#ifndef MYRIAD_VISIBILITY_GLSL
#define MYRIAD_VISIBILITY_GLSL

#include "scene_set.glsl"

layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_VERTICES) readonly buffer VertexBlock {
  float vertexData[];  // scene::Vertex: position 3, normal 3, uv 2, tangent 4, colour 4
};
layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_INDICES) readonly buffer IndexBlock {
  uint indexData[];
};
// [0]: x draws, y triangles in all. Then one per draw, in the raster path's draw order: x its
// first triangle id, y its first index, z its vertex offset (int bits), w its instance.
layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_DRAWS) readonly buffer DrawBlock {
  uvec4 visibilityDraws[];
};
layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_KEYS) buffer KeyBlock {
  uint64_t visibilityKeys[];
};

const uint kVertexFloats = 16u;

vec3 vertexVec3(uint vertex, uint offset) {
  uint b = vertex * kVertexFloats + offset;
  return vec3(vertexData[b], vertexData[b + 1u], vertexData[b + 2u]);
}
vec3 vertexPosition(uint vertex) { return vertexVec3(vertex, 0u); }
vec3 vertexNormal(uint vertex) { return vertexVec3(vertex, 3u); }
vec2 vertexUv(uint vertex) {
  uint b = vertex * kVertexFloats + 6u;
  return vec2(vertexData[b], vertexData[b + 1u]);
}
vec4 vertexColor(uint vertex) {
  uint b = vertex * kVertexFloats + 12u;
  return vec4(vertexData[b], vertexData[b + 1u], vertexData[b + 2u], vertexData[b + 3u]);
}

struct TriangleRef {
  uint instance;
  uint vertices[3];
};

// Triangle `id`'s instance and vertices: its draw is the last whose first triangle is <= id.
TriangleRef triangleRef(uint id) {
  uint lo = 1u;
  uint hi = visibilityDraws[0].x;
  while (lo < hi) {
    uint mid = (lo + hi + 1u) / 2u;
    if (visibilityDraws[mid].x <= id) {
      lo = mid;
    } else {
      hi = mid - 1u;
    }
  }
  uvec4 draw = visibilityDraws[lo];
  uint first = draw.y + 3u * (id - draw.x);
  TriangleRef t;
  t.instance = draw.w;
  for (uint i = 0u; i < 3u; ++i) {
    t.vertices[i] = uint(int(indexData[first + i]) + int(draw.z));
  }
  return t;
}

// A triangle ready for coverage tests: vertices in fixed point (1/256 pixel), wound so the three
// edge functions are positive inside; `bias` 0 on top and left edges (a pixel centre exactly on
// one is covered) and 1 elsewhere, Vulkan's and Direct3D's tie-breaking rule.
struct SetupTriangle {
  ivec2 v0;
  ivec2 v1;
  ivec2 v2;
  vec3 depth;    // z / w at v0, v1, v2
  float invArea;
  ivec3 bias;    // for the edges opposite v0, v1, v2
  uint id;
};

// Twice the signed area of (a, b, p), in fixed point squared.
int64_t edgeFunction(ivec2 a, ivec2 b, ivec2 p) {
  return int64_t(b.x - a.x) * int64_t(p.y - a.y) - int64_t(b.y - a.y) * int64_t(p.x - a.x);
}

// The edge a -> b of a positively wound triangle (y down) is a top edge (horizontal, going right)
// or a left edge (going up).
int edgeBias(ivec2 a, ivec2 b) {
  ivec2 e = b - a;
  return (e.y < 0 || (e.y == 0 && e.x > 0)) ? 0 : 1;
}

SetupTriangle unpackTriangle(VisibilityTriangle q) {
  SetupTriangle t;
  t.v0 = ivec2(q.xy01.xy);
  t.v1 = ivec2(q.xy01.zw);
  t.v2 = ivec2(q.xy2Depth.xy);
  t.depth = vec3(uintBitsToFloat(q.xy2Depth.z), uintBitsToFloat(q.xy2Depth.w),
                 uintBitsToFloat(q.depthId.x));
  t.id = q.depthId.y;
  t.invArea = 1.0 / float(edgeFunction(t.v0, t.v1, t.v2));
  t.bias = ivec3(edgeBias(t.v1, t.v2), edgeBias(t.v2, t.v0), edgeBias(t.v0, t.v1));
  return t;
}

#ifdef MYRIAD_VISIBILITY_WRITES_KEYS
// Pixel `pixel` (its centre) against the triangle; covered and in the depth range: the key.
void coverPixel(SetupTriangle t, ivec2 pixel) {
  const int centre = 1 << (MYRIAD_VISIBILITY_SUBPIXEL_BITS - 1);
  ivec2 p = (pixel << MYRIAD_VISIBILITY_SUBPIXEL_BITS) + centre;
  int64_t e0 = edgeFunction(t.v1, t.v2, p);
  int64_t e1 = edgeFunction(t.v2, t.v0, p);
  int64_t e2 = edgeFunction(t.v0, t.v1, p);
  if (e0 < int64_t(t.bias.x) || e1 < int64_t(t.bias.y) || e2 < int64_t(t.bias.z)) return;
  // Depth is linear in screen space (z / w at the vertices), as rasterisers interpolate it.
  float z = (float(e0) * t.depth.x + float(e1) * t.depth.y + float(e2) * t.depth.z) * t.invArea;
  // Clipped to [0, 1] without depth clamp; the cleared depth is 1 and the test LESS, so 1 fails.
  if (!(z >= 0.0 && z < 1.0)) return;
  uint64_t key = (uint64_t(floatBitsToUint(z) & 0x7FFFFFFFu) << 32) | uint64_t(t.id);
  uint index = uint(pixel.y) * uint(frame.viewport.x) + uint(pixel.x);
  atomicMin(visibilityKeys[index], key);
}
#endif

#endif
