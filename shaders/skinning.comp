#version 450
#extension GL_GOOGLE_include_directive : require
// The skinning pre-pass (render/skinning.cpp): one thread per vertex of a posed instance
// (workgroup y: the instance's job, from push.mode.y). glTF 2.0's order: the morph targets' displacements, times
// their weights, are added to the rest vertex; then the skin blends the joint matrices by the
// vertex's weights and moves position, normal and tangent by the blend (as three.js and the glTF
// sample viewer do: the normal by the blended matrix itself, then normalised). The result is in
// the asset's space; the instance's transform places it, as for any vertex.
#include "shared_types.h"

layout(local_size_x = MYRIAD_SKIN_GROUP) in;

layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_VERTICES) buffer VertexBlock {
  float vertices[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_INFLUENCES) readonly buffer InfluenceBlock {
  uvec4 influences[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_MORPHS) readonly buffer MorphBlock {
  float morphs[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_TARGETS) readonly buffer TargetBlock {
  uvec4 targets[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_JOBS) readonly buffer JobBlock {
  SkinJob jobs[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_POSE) readonly buffer PoseBlock {
  vec4 pose[];
};
layout(std430, set = 0, binding = MYRIAD_SKIN_BINDING_PREVIOUS) writeonly buffer PreviousBlock {
  vec4 previous[];
};
layout(push_constant) uniform SkinBlock {
  SkinPush push;
};

vec3 loadVec3(uint at) { return vec3(vertices[at], vertices[at + 1u], vertices[at + 2u]); }
vec3 morphVec3(uint at) { return vec3(morphs[at], morphs[at + 1u], morphs[at + 2u]); }
void storeVec3(uint at, vec3 v) {
  vertices[at] = v.x;
  vertices[at + 1u] = v.y;
  vertices[at + 2u] = v.z;
}

void main() {
  const SkinJob job = jobs[push.mode.y + gl_WorkGroupID.y];
  const uint v = gl_GlobalInvocationID.x;
  if (v >= job.vertices.y) return;
  const uint rest = (job.vertices.x + v) * MYRIAD_VERTEX_FLOATS;
  vec3 position = loadVec3(rest);
  vec3 normal = loadVec3(rest + 3u);
  vec3 tangent = loadVec3(rest + 8u);

  for (uint k = 0u; k < job.morph.y; ++k) {
    const uint w = job.morph.z + k;
    const float weight = pose[w >> 2u][w & 3u];
    if (weight == 0.0) continue;
    const uvec4 target = targets[job.morph.x + k];
    if (target.x != MYRIAD_SKIN_NONE) position += weight * morphVec3(target.x + 3u * v);
    if (target.y != MYRIAD_SKIN_NONE) normal += weight * morphVec3(target.y + 3u * v);
    if (target.z != MYRIAD_SKIN_NONE) tangent += weight * morphVec3(target.z + 3u * v);
  }

  if (job.skin.x != MYRIAD_SKIN_NONE) {
    const uvec4 joints = influences[2u * (job.skin.x + v)];
    const vec4 weights = uintBitsToFloat(influences[2u * (job.skin.x + v) + 1u]);
    vec4 row0 = vec4(0.0), row1 = vec4(0.0), row2 = vec4(0.0);
    float sum = 0.0;
    for (int i = 0; i < 4; ++i) {
      // A joint past the skin's (a malformed file) contributes nothing.
      if (weights[i] == 0.0 || joints[i] >= job.skin.z) continue;
      const uint m = job.skin.y + 3u * joints[i];
      row0 += weights[i] * pose[m];
      row1 += weights[i] * pose[m + 1u];
      row2 += weights[i] * pose[m + 2u];
      sum += weights[i];
    }
    if (sum > 0.0) {
      row0 /= sum;
      row1 /= sum;
      row2 /= sum;
      const vec4 p = vec4(position, 1.0);
      position = vec3(dot(row0, p), dot(row1, p), dot(row2, p));
      normal = vec3(dot(row0.xyz, normal), dot(row1.xyz, normal), dot(row2.xyz, normal));
      tangent = vec3(dot(row0.xyz, tangent), dot(row1.xyz, tangent), dot(row2.xyz, tangent));
    }
  }

  if (push.mode.x == 1u) {
    previous[job.vertices.w + v] = vec4(position, 1.0);
    return;
  }
  const uint posed = (job.vertices.z + v) * MYRIAD_VERTEX_FLOATS;
  storeVec3(posed, position);
  const float n = length(normal);
  storeVec3(posed + 3u, n > 0.0 ? normal / n : normal);
  // The tangent's sign (w) and the uv and colour were copied with the rest vertex once.
  const float t = length(tangent);
  storeVec3(posed + 8u, t > 0.0 ? tangent / t : tangent);
}
