#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// The visibility pass of the G-buffer rasterised in compute: one thread per triangle. It
// transforms the triangle as gbuffer.vert does, culls it as the raster pipeline would (outside
// the view, back faces of single-sided materials, no pixel centre covered), clips it where it
// crosses the near plane or leaves the guard band, and either covers the pixel centres of its
// box itself (small triangles) or queues it for the tile pass (visibility_tiles.comp).
#define MYRIAD_VISIBILITY_WRITES_KEYS
#include "visibility.glsl"

layout(local_size_x = MYRIAD_VISIBILITY_GROUP) in;

layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_LARGE) buffer LargeBlock {
  VisibilityLargeHeader largeHeader;
  VisibilityTriangle largeTriangles[];
};

// Signed distance of a clip-space point to clipping plane `plane`: the near plane (z >= 0,
// which also keeps w > 0), then the four sides of the guard band.
float planeDistance(vec4 c, int plane) {
  const float g = MYRIAD_VISIBILITY_GUARD_BAND;
  switch (plane) {
    case 0: return c.z;
    case 1: return g * c.w - c.x;
    case 2: return g * c.w + c.x;
    case 3: return g * c.w - c.y;
    default: return g * c.w + c.y;
  }
}

// Projects and snaps a (clipped) triangle, culls it, winds it positively. False: nothing to draw.
bool setupTriangle(vec4 c0, vec4 c1, vec4 c2, uint id, bool cullBack, out SetupTriangle t,
                   out ivec4 pixels) {
  const float subpixels = float(1 << MYRIAD_VISIBILITY_SUBPIXEL_BITS);
  vec2 size = frame.viewport.xy;
  // The viewport transform (x, y from 0, the whole target), then the rasteriser's snapping.
  t.v0 = ivec2(floor((c0.xy / c0.w * 0.5 + 0.5) * size * subpixels + 0.5));
  t.v1 = ivec2(floor((c1.xy / c1.w * 0.5 + 0.5) * size * subpixels + 0.5));
  t.v2 = ivec2(floor((c2.xy / c2.w * 0.5 + 0.5) * size * subpixels + 0.5));
  t.depth = vec3(c0.z / c0.w, c1.z / c1.w, c2.z / c2.w);
  t.id = id;
  int64_t area = edgeFunction(t.v0, t.v1, t.v2);
  if (area == 0) return false;
  // Counter-clockwise front faces (the pipeline's frontFace) have a negative area in
  // framebuffer coordinates, whose y points down.
  if (area > 0 && cullBack) return false;
  if (area < 0) {
    ivec2 v = t.v1;
    t.v1 = t.v2;
    t.v2 = v;
    t.depth = t.depth.xzy;
    area = -area;
  }
  t.invArea = 1.0 / float(area);
  t.bias = ivec3(edgeBias(t.v1, t.v2), edgeBias(t.v2, t.v0), edgeBias(t.v0, t.v1));
  // The pixel centres (x + 0.5 in fixed point) inside the snapped box, within the target.
  const int centre = 1 << (MYRIAD_VISIBILITY_SUBPIXEL_BITS - 1);
  ivec2 lo = min(min(t.v0, t.v1), t.v2);
  ivec2 hi = max(max(t.v0, t.v1), t.v2);
  ivec2 first = (lo - centre + (1 << MYRIAD_VISIBILITY_SUBPIXEL_BITS) - 1) >> MYRIAD_VISIBILITY_SUBPIXEL_BITS;
  ivec2 last = (hi - centre) >> MYRIAD_VISIBILITY_SUBPIXEL_BITS;
  first = max(first, ivec2(0));
  last = min(last, ivec2(size) - 1);
  pixels = ivec4(first, last);
  return all(lessThanEqual(first, last));
}

void coverBox(SetupTriangle t, ivec4 pixels) {
  for (int y = pixels.y; y <= pixels.w; ++y) {
    for (int x = pixels.x; x <= pixels.z; ++x) {
      coverPixel(t, ivec2(x, y));
    }
  }
}

void drawTriangle(vec4 c0, vec4 c1, vec4 c2, uint id, bool cullBack) {
  SetupTriangle t;
  ivec4 pixels;
  if (!setupTriangle(c0, c1, c2, id, cullBack, t, pixels)) return;
  ivec2 extent = pixels.zw - pixels.xy + 1;
  if (extent.x * extent.y > MYRIAD_VISIBILITY_SMALL_PIXELS) {
    uint slot = atomicAdd(largeHeader.groups.z, 1u);
    if (slot < MYRIAD_VISIBILITY_LARGE_CAPACITY) {
      VisibilityTriangle q;
      q.xy01 = uvec4(t.v0, t.v1);
      q.xy2Depth = uvec4(uvec2(t.v2), floatBitsToUint(t.depth.x), floatBitsToUint(t.depth.y));
      q.depthId = uvec4(floatBitsToUint(t.depth.z), id, 0u, 0u);
      q.pixels = uvec4(pixels);
      largeTriangles[slot] = q;
      return;
    }
    // The queue is full: this thread covers the box itself (slower, same pixels). Taking the
    // increment back leaves the count at the capacity, so the tile pass's dispatch stays valid.
    atomicAdd(largeHeader.groups.z, uint(-1));
  }
  coverBox(t, pixels);
}

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= visibilityDraws[0].y) return;
  TriangleRef ref = triangleRef(id);
  GpuInstance instance = instances[ref.instance];
  vec4 clip[3];
  for (uint i = 0u; i < 3u; ++i) {
    vec4 world = instance.model * vec4(vertexPosition(ref.vertices[i]), 1.0);
    clip[i] = frame.viewProjection * world;
  }
  // Wholly outside one side of the view volume: nothing of it is seen.
  for (int axis = 0; axis < 3; ++axis) {
    bool allBelow = true;
    bool allAbove = true;
    for (uint i = 0u; i < 3u; ++i) {
      float low = axis == 2 ? 0.0 : -clip[i].w;
      allBelow = allBelow && clip[i][axis] < low;
      allAbove = allAbove && clip[i][axis] > clip[i].w;
    }
    if (allBelow || allAbove) return;
  }
  bool cullBack = (materials[instance.material.x].flags.x & MYRIAD_MATERIAL_DOUBLE_SIDED) == 0u;

  bool clipped = false;
  for (int plane = 0; plane < 5; ++plane) {
    for (uint i = 0u; i < 3u; ++i) clipped = clipped || planeDistance(clip[i], plane) < 0.0;
  }
  if (!clipped) {
    drawTriangle(clip[0], clip[1], clip[2], id, cullBack);
    return;
  }
  // Sutherland-Hodgman against the near plane and the guard band: at most 3 + 5 vertices, then a
  // fan of triangles with the same id (the resolve pass intersects the original triangle).
  vec4 polygon[8];
  vec4 next[8];
  polygon[0] = clip[0];
  polygon[1] = clip[1];
  polygon[2] = clip[2];
  int count = 3;
  for (int plane = 0; plane < 5 && count >= 3; ++plane) {
    int kept = 0;
    for (int i = 0; i < count; ++i) {
      vec4 a = polygon[i];
      vec4 b = polygon[(i + 1) % count];
      float da = planeDistance(a, plane);
      float db = planeDistance(b, plane);
      if (da >= 0.0) next[kept++] = a;
      if ((da >= 0.0) != (db >= 0.0)) next[kept++] = mix(a, b, da / (da - db));
    }
    for (int i = 0; i < kept; ++i) polygon[i] = next[i];
    count = kept;
  }
  for (int i = 1; i + 1 < count; ++i) {
    drawTriangle(polygon[0], polygon[i], polygon[i + 1], id, cullBack);
  }
}
