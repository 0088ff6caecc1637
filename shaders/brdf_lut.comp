#version 450
#extension GL_GOOGLE_include_directive : require
// The split-sum BRDF table, once at start-up: x = N.V, y = perceptual roughness (texel centres).
#include "environment_pass.glsl"

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(MYRIAD_BRDF_LUT_SIZE * MYRIAD_BRDF_LUT_SIZE)) return;
  lutTexels[i] = vec4(brdfLutTexel(i % uint(MYRIAD_BRDF_LUT_SIZE), i / uint(MYRIAD_BRDF_LUT_SIZE)), 0.0, 0.0);
}
