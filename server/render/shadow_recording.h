// What the shadow passes share when they record (render/shadows.cpp holds the definitions; the
// sun's cascades in render/sun_shadows.cpp, the local lights' atlas in render/shadows.cpp).
// Internal to render/.
#pragma once

#include <vulkan/vulkan.h>

#include "gpu/resources.h"
#include "render/passes.h"
#include "render/scene_buffers.h"

namespace myriad::render::shadow_recording {

// Everything that samples a shadow map: the sun pass (fragment) and compute lighting.
inline constexpr VkPipelineStageFlags2 kShadowReaders =
    VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;

// Opens a depth-only rendering on `map` (the previous frame's lighting sampled it) with the
// shadow pipeline and the scene's geometry bound: cleared and rewritten whole, or with `keep`
// (a repair, ShadowMaps::repairSun) its contents loaded as they are. `scrolled`: the map was
// last written by scrollSun's copies (in GENERAL), not read as a map.
void beginShadowRendering(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                          const gpu::Image& map, bool keep = false, bool scrolled = false);
// Every instance casts, whatever its material: both faces, alpha-masked cut-outs as solid.
void drawCasters(VkCommandBuffer cmd, const SceneBuffers& scene);
// Ends the rendering; `map` becomes readable by the lighting passes.
void endShadowRendering(VkCommandBuffer cmd, const gpu::Image& map);

}  // namespace myriad::render::shadow_recording
