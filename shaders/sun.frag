#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) out vec4 outColor;       // HDR, RGBA16F
layout(location = 1) out float outLightCount;  // cleared here; light volumes add to it

void main() {
  outLightCount = 0.0;
  Surface s;
  if (!loadSurface(ivec2(gl_FragCoord.xy), s)) {
    outColor = vec4(backgroundRadiance(ivec2(gl_FragCoord.xy)), 1.0);
    return;
  }
  outColor = vec4(sunAndAmbient(s), 1.0);
}
