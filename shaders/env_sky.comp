#version 450
#extension GL_GOOGLE_include_directive : require
// Environment step 1 (mode sky): the procedural sky into source level 0.
#include "environment_pass.glsl"

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(MYRIAD_ENV_SOURCE_WIDTH * MYRIAD_ENV_SOURCE_HEIGHT)) return;
  uint x = i % uint(MYRIAD_ENV_SOURCE_WIDTH);
  uint y = i / uint(MYRIAD_ENV_SOURCE_WIDTH);
  sourceTexels[i] = vec4(skyTexel(x, y, params.sunDirection.xyz, params.sunColor.rgb), 1.0);
}
