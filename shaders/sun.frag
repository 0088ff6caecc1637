#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) out vec4 outColor;  // HDR, RGBA16F

void main() {
  Surface s;
  if (!loadSurface(ivec2(gl_FragCoord.xy), s)) {
    outColor = vec4(frame.background.rgb, 1.0);
    return;
  }
  vec3 sunRadiance = frame.sunColor.rgb * frame.sunDirection.w;
  vec3 color = shadeSunAndAmbient(s.normal, viewVector(s.position), s.baseColor, s.metallic,
                                  s.roughness, frame.sunDirection.xyz, sunRadiance,
                                  frame.ambient.rgb);
  outColor = vec4(color, 1.0);
}
