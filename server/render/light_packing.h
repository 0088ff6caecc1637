// A scene light as the GPU stores it (GpuPointLight, shaders/shared_types.h). The renderer uploads
// this and the reference renderer shades from it, so both see the same rounded values. Defined in
// reference.cpp, the one translation unit holding the C++ twin of the shading code (shading.h),
// whose octahedral encoding the spot direction uses.
#pragma once

#include "render/gpu_types.h"
#include "scene/scene.h"

namespace myriad::render {

// Position and radius; radiance (colour x intensity) and the attenuation (the window's C, or
// MYRIAD_ATTENUATION_INVERSE_SQUARE); the spot direction octahedral-encoded with cos(outer) and
// cos(inner) (a point light: MYRIAD_POINT_LIGHT_COS_OUTER/INNER, a cone holding every direction).
GpuPointLight packLight(const scene::PointLight& light);

// What the shaders decode from a packed light (frame.glsl's spotDirectionOf).
glm::vec3 spotDirectionOf(const GpuPointLight& light);

}  // namespace myriad::render
