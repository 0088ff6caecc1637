// The C++ reference renderer that judges GPU images: a brute-force ray caster over the scene's
// triangles that shades every pixel centre with the shaders' own shading code (render/shading.h),
// and rounds where the GPU stores (G-buffer formats, the half-float HDR target, 8-bit output), so
// a difference means the GPU pipeline is wrong, not that it stores less precisely. Slow on
// purpose: meant for small test images.
#pragma once

#include <cstdint>
#include <vector>

#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::render {

// RGBA8 like Frame::rgba. Supports every target but light-volumes (a rasterisation artefact);
// light markers are not drawn. Sun, ambient and background come from `settings`, as on the GPU.
std::vector<uint8_t> renderReference(const scene::Scene& scene, const FrameSettings& settings);

}  // namespace myriad::render
