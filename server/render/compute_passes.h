// The compute passes every technique shares: light animation. (The compute lighting of the tiled
// and clustered techniques lives with them, in render/techniques/.) Like passes.h, each function
// names what it reads and writes.
#pragma once

#include <vulkan/vulkan.h>

#include "render/passes.h"
#include "render/scene_buffers.h"

namespace myriad::render {

// Reads light origins and the frame time; writes every light's current position.
void recordAnimateLights(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene);

// Writes the lights back to their origins (after animated frames, for a still frame).
void recordRestoreLights(VkCommandBuffer cmd, const SceneBuffers& scene);

}  // namespace myriad::render
