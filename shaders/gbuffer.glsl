// The G-buffer pass's fragment stage, built twice: gbuffer.frag for opaque materials (no discard,
// so depth is tested and written before the shader runs) and gbuffer_alpha_test.frag for alphaMode
// MASK (MYRIAD_GBUFFER_ALPHA_TEST: discards below the cutoff, which defers the depth write until
// the shader has run). On the H200 the split took the floor scene's G-buffer from 1.514 to
// 1.461 ms at 1080p and 5.947 to 5.787 ms at 4K (docs/performance.md). Opaque materials without
// any texture get a third build, gbuffer_untextured.frag (MYRIAD_MATERIAL_UNTEXTURED: hasTexture
// is false, so the sampling and the normal map's tangent frame compile out): llvmpipe runs both
// sides of every branch, so the five texture samples cost every pixel whether or not the material
// has them (the built-in scene's G-buffer was about 2.5x slower with them).
#ifndef MYRIAD_GBUFFER_GLSL
#define MYRIAD_GBUFFER_GLSL
#include "frame.glsl"
#include "material.glsl"

layout(location = 0) out vec2 outNormal;     // octahedral, RG16_SNORM
layout(location = 1) out vec4 outBaseColor;  // RGBA8_SRGB
layout(location = 2) out vec4 outMaterial;   // metallic, roughness, occlusion, specular: RGBA8_UNORM
layout(location = 3) out vec2 outUv;         // RG16_SFLOAT
layout(location = 4) out vec4 outEmissive;   // emitted radiance: RGBA16_SFLOAT
layout(location = 5) out uvec2 outLayers;    // clear coat and sheen: RG32_UINT

void main() {
  GpuMaterial material = materialFromTexels(inMaterial);
  MaterialSample m = evaluateMaterial(material);
#ifdef MYRIAD_GBUFFER_ALPHA_TEST
  // Last (the derivatives are explicit, but a discarded pixel's quad neighbours still need it).
  if (m.baseColor.a < material.emissive.w) {
    discard;
  }
#endif
  GBufferTexels t = gbufferTexels(m);
  outNormal = t.normal;
  outBaseColor = t.baseColor;
  outMaterial = t.material;
  outUv = inUv;
  outEmissive = t.emissive;
  outLayers = t.layers;
}
#endif
