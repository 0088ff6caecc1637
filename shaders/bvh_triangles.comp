#version 450
#extension GL_GOOGLE_include_directive : require
// BVH step 1: one invocation per triangle of the draws the G-buffer draws (the draw table of
// visibility.glsl, posed vertices included: skinned instances' draws read their own region), into
// world space with its instance's transform, as gbuffer.vert places it. A triangle of an
// alpha-masked material whose alpha factor is below its cutoff and that has no base-colour
// texture is wholly cut out: it is kept (the hierarchy's size is the draw table's) but marked
// to cast no shadow. Textured cut-outs cast solid shadows (no bindless textures on lavapipe).
#include "bvh_build.glsl"

layout(local_size_x = MYRIAD_BVH_GROUP) in;

layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_VERTICES) readonly buffer VertexBlock {
  float vertexData[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_INDICES) readonly buffer IndexBlock {
  uint indexData[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_DRAWS) readonly buffer DrawBlock {
  uvec4 draws[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_INSTANCES) readonly buffer InstanceBlock {
  GpuInstance instances[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_MATERIALS) readonly buffer MaterialBlock {
  GpuMaterial materials[];
};

vec3 position(uint vertex) {
  uint b = vertex * uint(MYRIAD_VERTEX_FLOATS);
  return vec3(vertexData[b], vertexData[b + 1u], vertexData[b + 2u]);
}

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= triangleCount()) return;
  // The draw holding triangle `id`: the last whose first triangle is <= id.
  uint lo = 1u;
  uint hi = draws[0].x;
  while (lo < hi) {
    uint mid = (lo + hi + 1u) / 2u;
    if (draws[mid].x <= id) {
      lo = mid;
    } else {
      hi = mid - 1u;
    }
  }
  uvec4 draw = draws[lo];
  uint first = draw.y + 3u * (id - draw.x);
  GpuInstance instance = instances[draw.w];
  vec3 v[3];
  for (uint i = 0u; i < 3u; ++i) {
    uint vertex = uint(int(indexData[first + i]) + int(draw.z));
    v[i] = (instance.model * vec4(position(vertex), 1.0)).xyz;
  }
  GpuMaterial m = materials[instance.material.x];
  bool masked = (m.flags.x & MYRIAD_MATERIAL_ALPHA_MASK) != 0u;
  bool textured = (m.flags.x & 1u) != 0u;  // texture slot 0: base colour
  uint flags = masked && !textured && m.baseColor.a < m.emissive.w ? MYRIAD_BVH_TRIANGLE_CLEAR : 0u;
  BvhTriangle t;
  t.v0 = vec4(v[0], uintBitsToFloat(flags));
  t.v1 = vec4(v[1], 0.0);
  t.v2 = vec4(v[2], 0.0);
  triangles[id] = t;
}
