#version 450
#extension GL_GOOGLE_include_directive : require
// Environment step 2: source level params.step.x (>= 1) from the level above, 2x2 box filter.
#include "environment_pass.glsl"

void main() {
  uint level = params.step.x;
  uint w = uint(MYRIAD_ENV_SOURCE_WIDTH) >> level;
  uint h = uint(MYRIAD_ENV_SOURCE_HEIGHT) >> level;
  uint i = gl_GlobalInvocationID.x;
  if (i >= w * h) return;
  sourceTexels[envSourceOffset(level) + i] = vec4(downsampleTexel(level, i % w, i / w), 1.0);
}
