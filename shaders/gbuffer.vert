#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;

layout(location = 0) out vec3 outWorldPosition;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec2 outUv;
layout(location = 3) flat out uint outMaterial;

// One draw per instance; firstInstance carries the instance index into gl_InstanceIndex.
void main() {
  GpuInstance instance = instances[gl_InstanceIndex];
  vec4 world = instance.model * vec4(inPosition, 1.0);
  outWorldPosition = world.xyz;
  outNormal = mat3(instance.normalMatrix) * inNormal;
  outUv = inUv;
  outMaterial = instance.material.x;
  gl_Position = frame.viewProjection * world;
}
