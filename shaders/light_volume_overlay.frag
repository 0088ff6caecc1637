#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) flat in uint inLight;
layout(location = 0) out vec4 outColor;  // added to the output image (light-volumes view)

// The seed's "light space visible": every pixel a light's volume shades, tinted by its colour.
void main() {
  vec3 radiance = lights[inLight].radianceFalloff.rgb;
  float peak = max(radiance.r, max(radiance.g, radiance.b));
  vec3 hue = peak > 0.0 ? radiance / peak : vec3(0.0);
  outColor = vec4(hue * 0.12, 0.0);
}
