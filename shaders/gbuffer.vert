#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) in vec4 inTangent;  // w = 0: none in the file
layout(location = 4) in vec4 inColor;    // COLOR_0, linear

layout(location = 0) out vec3 outWorldPosition;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec2 outUv;
layout(location = 3) flat out uint outMaterial;
layout(location = 4) out vec4 outTangent;
layout(location = 5) out vec4 outColor;
layout(location = 6) flat out uvec2 outLabels;  // object, semantic class (labels.frag)

// One draw per instance; firstInstance carries the instance index into gl_InstanceIndex.
void main() {
  GpuInstance instance = instances[gl_InstanceIndex];
  vec4 world = instance.model * vec4(inPosition, 1.0);
  outWorldPosition = world.xyz;
  outNormal = mat3(instance.normalMatrix) * inNormal;
  outUv = inUv;
  outMaterial = instance.material.x;
  // Tangents follow the surface, so they transform with the model matrix (not the normal matrix).
  outTangent = vec4(mat3(instance.model) * inTangent.xyz, inTangent.w);
  outColor = inColor;
  outLabels = instance.material.yz;
  gl_Position = frame.viewProjection * world;
}
