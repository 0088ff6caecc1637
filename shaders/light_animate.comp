#version 450
#extension GL_GOOGLE_include_directive : require
// Moves every light on the GPU: position = origin + a Lissajous orbit whose size, speed and phase
// come from a hash of the light's index, evaluated at the frame's time. Stateless, so any frame is
// reproducible from the scene (origins from the seed) and the time alone; nothing is uploaded.
#include "frame.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;

layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_ORIGINS) readonly buffer OriginBlock {
  GpuPointLight origins[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) writeonly buffer MovingLightBlock {
  GpuPointLight movingLights[];
};

// PCG-style integer hash (Jarzynski & Olano, JCGT 2020) -> [0, 1).
float hash01(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return float((word >> 22u) ^ word) / 4294967296.0;
}

void main() {
  uint index = gl_GlobalInvocationID.x;
  if (index >= frame.flags.y) return;
  vec4 positionRadius = origins[index].positionRadius;
  float t = frame.slicing.w;
  float radius = positionRadius.w;
  float speed = 0.4 + 0.8 * hash01(index * 3u);
  float phase = 6.2831853 * hash01(index * 3u + 1u);
  float reach = radius * (0.5 + 0.5 * hash01(index * 3u + 2u));
  vec3 offset = reach * vec3(sin(speed * t + phase), 0.25 * sin(1.7 * speed * t + phase),
                             cos(0.8 * speed * t + phase));
  // Only the position moves: the rest of each light is the origin's already (every upload writes
  // both buffers, and restoring copies origins to lights), so a 16-byte read and write, not 48.
  movingLights[index].positionRadius = vec4(positionRadius.xyz + offset, radius);
}
