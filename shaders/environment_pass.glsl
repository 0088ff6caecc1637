// What the environment's compute passes share (render/environment.cpp): their own descriptor set
// (the scene's source pyramid, its lighting maps, the BRDF table) and push constants.
#ifndef MYRIAD_ENVIRONMENT_PASS_GLSL
#define MYRIAD_ENVIRONMENT_PASS_GLSL

#include "shared_types.h"
#include "shading.glsl"

layout(std430, set = 0, binding = MYRIAD_ENV_BINDING_SOURCE) buffer SourceBlock {
  vec4 sourceTexels[];
};
layout(std430, set = 0, binding = MYRIAD_ENV_BINDING_LIGHTING) buffer LightingBlock {
  vec4 lightingTexels[];
};
layout(std430, set = 0, binding = MYRIAD_ENV_BINDING_LUT) buffer LutBlock {
  vec4 lutTexels[];
};
layout(push_constant) uniform ParamsBlock {
  EnvironmentParams params;
};

#define MYRIAD_ENV_SOURCE(i) sourceTexels[i]
#include "environment.glsl"

layout(local_size_x = MYRIAD_ENV_GROUP) in;

#endif
