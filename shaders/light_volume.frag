#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) flat in uint inLight;
layout(location = 0) out vec4 outColor;  // added to the HDR target

// Runs once per pixel the light's back faces cover (and that passed the depth test: the surface
// is not behind the sphere). The exact test is here: only points inside the sphere get light.
void main() {
  Surface s;
  if (!loadSurface(ivec2(gl_FragCoord.xy), s)) {
    discard;
  }
  GpuPointLight light = lights[inLight];
  vec3 color = shadePointLight(s.position, s.normal, viewVector(s.position), s.baseColor,
                               s.metallic, s.roughness, light.positionRadius.xyz,
                               light.positionRadius.w, light.radianceFalloff.rgb,
                               light.radianceFalloff.w);
  outColor = vec4(color, 0.0);
}
