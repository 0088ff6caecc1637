// The compute passes: light animation, and the lighting of the tiled and clustered techniques.
// Like passes.h, each function names what it reads and writes.
#pragma once

#include <vulkan/vulkan.h>

#include "render/frame_targets.h"
#include "render/light_grid.h"
#include "render/passes.h"
#include "render/scene_buffers.h"

namespace myriad::render {

// Reads light origins and the frame time; writes every light's current position.
void recordAnimateLights(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene);

// Writes the lights back to their origins (after animated frames, for a still frame).
void recordRestoreLights(VkCommandBuffer cmd, const SceneBuffers& scene);

// Reads the G-buffer and lights; writes HDR and light counts (GENERAL layout) and the stats.
void recordTiledLighting(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                         const LightGrid& grid);

// Reads the G-buffer and lights; builds the cluster lists (mark, count, scan, assign), then
// writes HDR and light counts (GENERAL layout) and the stats.
void recordClusteredLighting(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                             const LightGrid& grid, const SceneBuffers& scene);

}  // namespace myriad::render
