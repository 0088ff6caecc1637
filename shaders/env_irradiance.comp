#version 450
#extension GL_GOOGLE_include_directive : require
// Environment step 3: the SH9 irradiance coefficients (one invocation each) into the header of
// the lighting maps; the header's other vec4s are zeroed.
#include "environment_pass.glsl"

void main() {
  uint k = gl_GlobalInvocationID.x;
  if (k >= uint(MYRIAD_ENV_HEADER)) return;
  lightingTexels[k] = k < 9u ? vec4(projectSH(k), 0.0) : vec4(0.0);
}
