#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) flat in uint inLight;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec4 outColor;  // HDR

// A small emissive ball in the light's hue, bright at the centre and a little darker at the rim
// so it reads as a sphere. Divided by exposure so it looks the same at any exposure.
void main() {
  vec3 radiance = lights[inLight].radianceFalloff.rgb;
  float peak = max(radiance.r, max(radiance.g, radiance.b));
  vec3 hue = peak > 0.0 ? radiance / peak : vec3(0.0);
  vec3 toEye = normalize(frame.cameraPosition.xyz - lights[inLight].positionRadius.xyz);
  float facing = abs(dot(normalize(inNormal), toEye));
  outColor = vec4(hue * (0.55 + 0.6 * facing) / frame.camera.x, 1.0);
}
