#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"
#include "material.glsl"

layout(location = 0) out vec2 outNormal;     // octahedral, RG16_SNORM
layout(location = 1) out vec4 outBaseColor;  // RGBA8_SRGB
layout(location = 2) out vec4 outMaterial;   // metallic, roughness, occlusion: RGBA8_UNORM
layout(location = 3) out vec2 outUv;         // RG16_SFLOAT
layout(location = 4) out vec4 outEmissive;   // emitted radiance: RGBA16_SFLOAT

void main() {
  GpuMaterial material = materials[inMaterial];
  MaterialSample m = evaluateMaterial(material);
  // Last (the derivatives are explicit, but a discarded pixel's quad neighbours still need it).
  if ((material.flags.x & MYRIAD_MATERIAL_ALPHA_MASK) != 0u && m.baseColor.a < material.emissive.w) {
    discard;
  }
  outNormal = octahedralEncode(m.normal);
  outBaseColor = vec4(clamp(m.baseColor.rgb, 0.0, 1.0), 1.0);
  outMaterial = vec4(clamp(vec3(m.metallic, m.roughness, m.occlusion), 0.0, 1.0), 1.0);
  outUv = inUv;
  outEmissive = vec4(m.emissive, 1.0);
}
