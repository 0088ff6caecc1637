// The C++ reference renderer that judges GPU images: a ray caster over the scene's triangles that
// shades every pixel centre with the shaders' own shading code (render/shading.h), and rounds
// where the GPU stores (G-buffer formats, the half-float HDR target, 8-bit output), so a
// difference means the GPU pipeline is wrong, not that it stores less precisely. Exact rather
// than fast: every light's shadow is a ray per pixel (where the frame shadows it). Its rays go
// through a CPU BVH of its own (render/reference_bvh.h: brute force's answers, faster) and its
// rows over the machine's cores, so the built-in scene with 10,000 shadowed lights at 96x64
// takes seconds; still meant for small test images.
#pragma once

#include <cstdint>
#include <vector>

#include "render/frame.h"
#include "scene/environment_map.h"
#include "scene/scene.h"

namespace myriad::render {

// RGBA8 like Frame::rgba. Supports every target but light-volumes (a rasterisation artefact);
// light markers are not drawn. Sun, ambient and background come from `settings`, as on the GPU.
// The environment (settings.environment) is built on the CPU by the very functions the GPU's
// passes run (shaders/environment.glsl: same sizes, same sample pattern, same bilinear taps);
// `hdr` takes `environmentImage` (the image given to Renderer::setEnvironmentImage) and throws
// std::invalid_argument without one.
// `radiance`, when given (target final): each pixel's HDR radiance before exposure and tone
// mapping, rows top first (what a raw final frame holds): for tests that average frames.
std::vector<uint8_t> renderReference(const scene::Scene& scene, const FrameSettings& settings,
                                     const scene::EnvironmentImage* environmentImage = nullptr,
                                     std::vector<glm::vec3>* radiance = nullptr);

// The labels of each pixel centre's first hit (rows top first): object, semantic class, material,
// 1; all 0 where the ray meets nothing before the far plane. What the label pass must give.
std::vector<glm::uvec4> referenceLabels(const scene::Scene& scene, const FrameSettings& settings);

// The environment's maps as the GPU builds them (for tests): the source pyramid, the lighting maps
// (SH9 header + specular levels) and the BRDF table, vec4 each, in the GPU buffers' layout.
struct EnvironmentMaps {
  std::vector<glm::vec4> source;
  std::vector<glm::vec4> lighting;
  std::vector<glm::vec4> lut;
};
EnvironmentMaps buildEnvironmentMaps(const FrameSettings& settings,
                                     const scene::EnvironmentImage* environmentImage);

}  // namespace myriad::render
