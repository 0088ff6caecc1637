// Shared by C++ and GLSL: binding indices, constants and GPU struct layouts.
//
// Every struct here is std140/std430-compatible by construction: only vec4, uvec4 and mat4
// members, so the two layouts agree and C++ needs no padding rules. The C++ side checks sizes and
// offsets with static_assert (server/render/gpu_types.h); change a struct here and both sides see it.
#ifndef MYRIAD_SHARED_TYPES_H
#define MYRIAD_SHARED_TYPES_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace myriad::gpu_types {
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#define MYRIAD_STRUCT(name) struct name
#else
#define MYRIAD_STRUCT(name) struct name
#endif

// Descriptor set 0: the scene (changes when the scene changes).
#define MYRIAD_SET_SCENE 0
#define MYRIAD_BINDING_FRAME 0      // uniform FrameUniforms
#define MYRIAD_BINDING_LIGHTS 1     // storage GpuPointLight[]
#define MYRIAD_BINDING_INSTANCES 2  // storage GpuInstance[]
#define MYRIAD_BINDING_MATERIALS 3  // storage GpuMaterial[]

// Descriptor set 1: the frame's render targets, read by later passes (changes with the size).
#define MYRIAD_SET_TARGETS 1
#define MYRIAD_BINDING_GBUFFER_DEPTH 0
#define MYRIAD_BINDING_GBUFFER_NORMAL 1
#define MYRIAD_BINDING_GBUFFER_BASE_COLOR 2
#define MYRIAD_BINDING_GBUFFER_MATERIAL 3
#define MYRIAD_BINDING_GBUFFER_UV 4
#define MYRIAD_BINDING_HDR 5

// The view the tonemap pass writes (FrameUniforms.flags.x). Order matches render::Target.
#define MYRIAD_VIEW_FINAL 0
#define MYRIAD_VIEW_ALBEDO 1
#define MYRIAD_VIEW_NORMAL 2
#define MYRIAD_VIEW_POSITION 3
#define MYRIAD_VIEW_UV 4
#define MYRIAD_VIEW_METALLIC 5
#define MYRIAD_VIEW_ROUGHNESS 6
#define MYRIAD_VIEW_DEPTH 7
#define MYRIAD_VIEW_LIGHT_VOLUMES 8

MYRIAD_STRUCT(FrameUniforms) {
  mat4 view;
  mat4 projection;
  mat4 viewProjection;
  mat4 inverseViewProjection;
  vec4 cameraPosition;   // xyz world position, w unused
  vec4 sunDirection;     // xyz unit vector pointing towards the sun, w = intensity
  vec4 sunColor;         // rgb linear, w unused
  vec4 ambient;          // rgb ambient radiance, w unused
  vec4 background;       // rgb radiance where no geometry was drawn, w unused
  vec4 viewport;         // width, height, 1/width, 1/height
  vec4 camera;           // x exposure, y near, z far, w light-marker radius (world units)
  vec4 boundsMin;        // scene bounds, for the position view; w unused
  vec4 boundsMax;
  uvec4 flags;           // x view (MYRIAD_VIEW_*), y light count, z, w unused
};

// A local point light. radiance = color * intensity; attenuation slope C in radianceFalloff.w.
MYRIAD_STRUCT(GpuPointLight) {
  vec4 positionRadius;   // xyz world position, w radius (attenuation is exactly 0 from here on)
  vec4 radianceFalloff;  // rgb radiance, w attenuation constant C
};

MYRIAD_STRUCT(GpuInstance) {
  mat4 model;
  mat4 normalMatrix;     // inverse-transpose of model (upper 3x3 used)
  uvec4 material;        // x material index
};

MYRIAD_STRUCT(GpuMaterial) {
  vec4 baseColor;          // linear rgb, a unused
  vec4 metallicRoughness;  // x metallic, y perceptual roughness
};

#ifdef __cplusplus
}  // namespace myriad::gpu_types
#endif
#endif
