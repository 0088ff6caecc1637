#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) flat in uint inLight;
layout(location = 0) out vec4 outColor;       // added to the HDR target
layout(location = 1) out float outLightCount;  // added to the light count

// Runs once per pixel the light's back faces cover (and that passed the depth test: the surface
// is not behind the sphere). The exact test is here: only points inside the sphere get light.
void main() {
  Surface s;
  if (!loadSurface(ivec2(gl_FragCoord.xy), s)) {
    discard;
  }
  bool reaches = lightReaches(s, inLight);
  outColor = vec4(reaches ? shadeLightShadowed(s, inLight) : vec3(0.0), 0.0);
  outLightCount = reaches ? 1.0 : 0.0;
}
