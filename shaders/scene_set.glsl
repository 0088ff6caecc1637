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
// The same materials as texels (shared_types.h MYRIAD_BINDING_MATERIAL_TEXELS says why).
layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_MATERIAL_TEXELS) uniform usamplerBuffer materialTexels;

// materials[m], read from materialTexels: what the G-buffer's fragments read (on lavapipe the
// built-in scene's G-buffer at 1280x720 took 40-43 ms so against 44-46 from the storage buffer).
GpuMaterial materialFromTexels(uint m) {
  int at = int(m) * MYRIAD_MATERIAL_TEXELS;
  GpuMaterial material;
  material.baseColor = uintBitsToFloat(texelFetch(materialTexels, at));
  material.metallicRoughness = uintBitsToFloat(texelFetch(materialTexels, at + 1));
  material.emissive = uintBitsToFloat(texelFetch(materialTexels, at + 2));
  material.flags = texelFetch(materialTexels, at + 3);
  for (int i = 0; i < 2 * MYRIAD_TEXTURE_SLOTS; ++i) {
    material.uvTransform[i] = uintBitsToFloat(texelFetch(materialTexels, at + 4 + i));
  }
  int layersAt = at + 4 + 2 * MYRIAD_TEXTURE_SLOTS;
  material.layers = uintBitsToFloat(texelFetch(materialTexels, layersAt));
  material.sheenColor = uintBitsToFloat(texelFetch(materialTexels, layersAt + 1));
  return material;
}

#endif
