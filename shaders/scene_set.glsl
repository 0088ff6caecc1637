// Set 0's frame uniforms, instances and materials: what every pass that draws the scene's
// surfaces reads (frame.glsl for the raster and lighting passes; visibility.glsl for the
// G-buffer rasterised in compute, which has its own set 1).
#ifndef MYRIAD_SCENE_SET_GLSL
#define MYRIAD_SCENE_SET_GLSL

#include "shared_types.h"

layout(std140, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_INSTANCES) readonly buffer InstanceBlock {
  GpuInstance instances[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_MATERIALS) readonly buffer MaterialBlock {
  GpuMaterial materials[];
};

#endif
