#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) in vec3 inPosition;

layout(location = 0) flat out uint outLight;
layout(location = 1) out vec3 outNormal;

void main() {
  GpuPointLight light = lights[gl_InstanceIndex];
  vec3 world = light.positionRadius.xyz + inPosition * frame.camera.w;
  outLight = gl_InstanceIndex;
  outNormal = normalize(inPosition);
  gl_Position = frame.viewProjection * vec4(world, 1.0);
}
