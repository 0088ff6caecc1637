#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) in vec3 inPosition;  // the sphere proxy, circumscribing the unit sphere

layout(location = 0) flat out uint outLight;

// One instance per light: the proxy scaled to the light's radius around its position.
void main() {
  GpuPointLight light = lights[gl_InstanceIndex];
  vec3 world = light.positionRadius.xyz + inPosition * light.positionRadius.w;
  outLight = gl_InstanceIndex;
  gl_Position = frame.viewProjection * vec4(world, 1.0);
}
