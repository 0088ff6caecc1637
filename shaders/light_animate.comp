#version 450
#extension GL_GOOGLE_include_directive : require
// Moves every light on the GPU along its orbit (light_orbit.glsl) at the frame's time; nothing is
// uploaded. The clustered technique on GPUs does this in its counting pass instead.
#include "frame.glsl"
#include "light_orbit.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;

layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_ORIGINS) readonly buffer OriginBlock {
  GpuPointLight origins[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) writeonly buffer MovingLightBlock {
  GpuPointLight movingLights[];
};

void main() {
  uint index = gl_GlobalInvocationID.x;
  if (index >= frame.flags.y) return;
  // Only the position moves: the rest of each light is the origin's already (every upload writes
  // both buffers, and restoring copies origins to lights), so a 16-byte read and write, not 48.
  movingLights[index].positionRadius = orbitPosition(index, origins[index].positionRadius, frame.slicing.w);
}
