// The GPU struct layouts of shaders/shared_types.h, checked on the C++ side: std140/std430 offsets
// of every member must equal the C++ offsets, or uploads silently scramble.
#pragma once

#include <cstddef>

#include "shared_types.h"

namespace myriad::render {

using gpu_types::FrameUniforms;
using gpu_types::GpuInstance;
using gpu_types::GpuMaterial;
using gpu_types::GpuPointLight;
using gpu_types::CullingStats;

static_assert(sizeof(gpu_types::vec4) == 16 && sizeof(gpu_types::mat4) == 64);
static_assert(sizeof(FrameUniforms) == 4 * 64 + 12 * 16);
static_assert(offsetof(FrameUniforms, inverseViewProjection) == 192);
static_assert(offsetof(FrameUniforms, cameraPosition) == 256);
static_assert(offsetof(FrameUniforms, viewport) == 256 + 5 * 16);
static_assert(offsetof(FrameUniforms, flags) == 256 + 9 * 16);
static_assert(offsetof(FrameUniforms, slicing) == 256 + 11 * 16);
static_assert(sizeof(CullingStats) == 32);
static_assert(sizeof(GpuPointLight) == 32 && offsetof(GpuPointLight, radianceFalloff) == 16);
static_assert(sizeof(GpuInstance) == 144 && offsetof(GpuInstance, material) == 128);
static_assert(sizeof(GpuMaterial) == 32 && offsetof(GpuMaterial, metallicRoughness) == 16);

}  // namespace myriad::render
