#version 450
#extension GL_GOOGLE_include_directive : require
// Environment step 4: every prefiltered specular level (GGX importance sampled), one invocation
// per texel of all levels.
#include "environment_pass.glsl"

void main() {
  const uint size = uint(MYRIAD_ENV_SPECULAR_WIDTH * MYRIAD_ENV_SPECULAR_HEIGHT);
  uint i = gl_GlobalInvocationID.x;
  if (i >= size * uint(MYRIAD_ENV_SPECULAR_LEVELS)) return;
  uint level = i / size;
  uint texel = i % size;
  vec3 c = prefilterTexel(level, texel % uint(MYRIAD_ENV_SPECULAR_WIDTH),
                          texel / uint(MYRIAD_ENV_SPECULAR_WIDTH));
  lightingTexels[uint(MYRIAD_ENV_HEADER) + i] = vec4(c, 1.0);
}
