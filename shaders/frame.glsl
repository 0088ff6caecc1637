// Declarations every pass shares: the frame uniforms, the scene buffers and the G-buffer, plus
// surface reconstruction from the G-buffer (position comes from depth; nothing stores it).
#ifndef MYRIAD_FRAME_GLSL
#define MYRIAD_FRAME_GLSL

#include "shared_types.h"
#include "shading.glsl"

layout(std140, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) readonly buffer LightBlock {
  GpuPointLight lights[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_INSTANCES) readonly buffer InstanceBlock {
  GpuInstance instances[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_MATERIALS) readonly buffer MaterialBlock {
  GpuMaterial materials[];
};

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_DEPTH) uniform sampler2D gbufferDepth;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_NORMAL) uniform sampler2D gbufferNormal;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_BASE_COLOR) uniform sampler2D gbufferBaseColor;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_MATERIAL) uniform sampler2D gbufferMaterial;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_UV) uniform sampler2D gbufferUv;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_HDR) uniform sampler2D hdrColor;

struct Surface {
  vec3 position;
  vec3 normal;
  vec3 baseColor;
  float metallic;
  float roughness;
};

// World position of the pixel centre at `pixel` with G-buffer depth `depth`.
vec3 worldFromDepth(ivec2 pixel, float depth) {
  vec2 ndc = (vec2(pixel) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 p = frame.inverseViewProjection * vec4(ndc, depth, 1.0);
  return p.xyz / p.w;
}

// False where no geometry was drawn (depth still at the cleared far value).
bool loadSurface(ivec2 pixel, out Surface s) {
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  if (depth >= 1.0) {
    return false;
  }
  s.position = worldFromDepth(pixel, depth);
  s.normal = octahedralDecode(texelFetch(gbufferNormal, pixel, 0).rg);
  s.baseColor = texelFetch(gbufferBaseColor, pixel, 0).rgb;  // sRGB format: sampled as linear
  vec2 material = texelFetch(gbufferMaterial, pixel, 0).rg;
  s.metallic = material.x;
  s.roughness = material.y;
  return true;
}

vec3 viewVector(vec3 position) {
  return normalize(frame.cameraPosition.xyz - position);
}

#endif
