// The GPU struct layouts of shaders/shared_types.h, checked on the C++ side: std140/std430 offsets
// of every member must equal the C++ offsets, or uploads silently scramble.
#pragma once

#include <cstddef>

#include "render/frame.h"
#include "shared_types.h"

namespace myriad::render {

using gpu_types::FrameUniforms;
using gpu_types::GpuInstance;
using gpu_types::GpuMaterial;
using gpu_types::GpuPointLight;
using gpu_types::CullingStats;
using gpu_types::LargeLightQueue;

static_assert(sizeof(gpu_types::vec4) == 16 && sizeof(gpu_types::mat4) == 64);
static_assert(sizeof(gpu_types::GpuLightShadow) == 64 + 3 * 16);
static_assert(sizeof(FrameUniforms) == 4 * 64 + 16 * 16 + 2 * MYRIAD_MAX_EXTRA_SUNS * 16 +
                                           MYRIAD_MAX_SUN_CASCADES * (64 + 16) + 16 +
                                           16 + MYRIAD_MAX_SHADOWED_LIGHTS / 4 * 16 +
                                           MYRIAD_MAX_SHADOWED_LIGHTS * (64 + 3 * 16) + 16 + 16);
static_assert(offsetof(FrameUniforms, fog) == sizeof(FrameUniforms) - 16);
static_assert(MYRIAD_MAX_SHADOWED_LIGHTS % 4 == 0);
static_assert(MYRIAD_MAX_SHADOWED_LIGHTS == kMaxShadowedLights);
static_assert(MYRIAD_SHADOWED_LIGHTS_DEFAULT == kDefaultShadowedLights);
static_assert(offsetof(FrameUniforms, sunShadowMatrix) == 256 + 16 * 16 + 2 * MYRIAD_MAX_EXTRA_SUNS * 16);
static_assert(sizeof(gpu_types::ShadowPush) == 64);
static_assert(sizeof(gpu_types::TemporalPush) == 64 + 3 * 16);  // within 128 B of push constants
static_assert(offsetof(FrameUniforms, environment) == 256 + 13 * 16);
static_assert(offsetof(FrameUniforms, post) == 256 + 15 * 16);
static_assert(offsetof(FrameUniforms, extraSunDirection) == 256 + 16 * 16);
static_assert(MYRIAD_MAX_EXTRA_SUNS == scene::kMaxExtraSuns);
static_assert(sizeof(gpu_types::EnvironmentParams) == 48);
static_assert(offsetof(FrameUniforms, inverseViewProjection) == 192);
static_assert(offsetof(FrameUniforms, cameraPosition) == 256);
static_assert(offsetof(FrameUniforms, viewport) == 256 + 5 * 16);
static_assert(offsetof(FrameUniforms, flags) == 256 + 9 * 16);
static_assert(offsetof(FrameUniforms, written) == 256 + 11 * 16);
static_assert(offsetof(FrameUniforms, slicing) == 256 + 12 * 16);
static_assert(sizeof(CullingStats) == 32);
static_assert(sizeof(LargeLightQueue) == 32);
static_assert(sizeof(gpu_types::AntialiasEdges) == 32);
static_assert(sizeof(gpu_types::VisibilityLargeHeader) == 16 && sizeof(gpu_types::VisibilityTriangle) == 64);
static_assert(sizeof(GpuPointLight) == 48 && offsetof(GpuPointLight, radianceFalloff) == 16 &&
              offsetof(GpuPointLight, cone) == 32);
static_assert(sizeof(GpuInstance) == 144 && offsetof(GpuInstance, material) == 128);
static_assert(sizeof(GpuMaterial) == 96 + 16 * 2 * MYRIAD_TEXTURE_SLOTS &&
              offsetof(GpuMaterial, metallicRoughness) == 16 && offsetof(GpuMaterial, flags) == 48 &&
              offsetof(GpuMaterial, uvTransform) == 64 &&
              offsetof(GpuMaterial, layers) == 64 + 16 * 2 * MYRIAD_TEXTURE_SLOTS &&
              offsetof(GpuMaterial, sheenColor) == 80 + 16 * 2 * MYRIAD_TEXTURE_SLOTS);
// The texel views (MYRIAD_BINDING_LIGHT_TEXELS, _MATERIAL_TEXELS): one 16-byte texel a member.
static_assert(sizeof(GpuPointLight) == 16 * MYRIAD_LIGHT_TEXELS &&
              sizeof(GpuMaterial) == 16 * MYRIAD_MATERIAL_TEXELS);

static_assert(uint32_t(EnvironmentMode::None) == MYRIAD_ENV_NONE);
static_assert(uint32_t(EnvironmentMode::Sky) == MYRIAD_ENV_SKY);
static_assert(uint32_t(EnvironmentMode::Hdr) == MYRIAD_ENV_HDR);
static_assert(protocol::kEnvironmentModes.size() == 3);

static_assert(uint32_t(Antialias::None) == MYRIAD_ANTIALIAS_NONE);
static_assert(uint32_t(Antialias::Fxaa) == MYRIAD_ANTIALIAS_FXAA);

// The view numbers of the final and views passes are render::Target's values.
static_assert(uint32_t(Target::Final) == MYRIAD_VIEW_FINAL);
static_assert(uint32_t(Target::Albedo) == MYRIAD_VIEW_ALBEDO);
static_assert(uint32_t(Target::Normal) == MYRIAD_VIEW_NORMAL);
static_assert(uint32_t(Target::Position) == MYRIAD_VIEW_POSITION);
static_assert(uint32_t(Target::Uv) == MYRIAD_VIEW_UV);
static_assert(uint32_t(Target::Metallic) == MYRIAD_VIEW_METALLIC);
static_assert(uint32_t(Target::Roughness) == MYRIAD_VIEW_ROUGHNESS);
static_assert(uint32_t(Target::Depth) == MYRIAD_VIEW_DEPTH);
static_assert(uint32_t(Target::LightVolumes) == MYRIAD_VIEW_LIGHT_VOLUMES);
static_assert(uint32_t(Target::LightCount) == MYRIAD_VIEW_LIGHT_COUNT);
static_assert(uint32_t(Target::Clusters) == MYRIAD_VIEW_CLUSTERS);
static_assert(uint32_t(Target::Emissive) == MYRIAD_VIEW_EMISSIVE);
static_assert(uint32_t(Target::Occlusion) == MYRIAD_VIEW_OCCLUSION);
static_assert(uint32_t(Target::Shadow) == MYRIAD_VIEW_SHADOW);
static_assert(MYRIAD_MAX_SUN_CASCADES == kMaxSunCascades);
static_assert(MYRIAD_SUN_CASCADES_DEFAULT == kDefaultSunCascades);

}  // namespace myriad::render
