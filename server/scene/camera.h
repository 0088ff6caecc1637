#pragma once

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace myriad::scene {

// Right-handed view matrix looking from camera.eye at camera.target.
glm::mat4 viewMatrix(const Camera& camera);

// Vulkan clip space: depth 0 at the near plane, 1 at the far plane, +y down in the image.
glm::mat4 projectionMatrix(const Camera& camera, float aspect);

// A camera that sees all of `bounds` at the given vertical field of view and aspect ratio, looking
// from the front-right and above; near/far enclose the bounds with margin.
Camera frameBounds(const Bounds& bounds, float fovYDegrees = 50.0f, float aspect = 16.0f / 9.0f);

// As above, with the eye placed along `towardsEye` (from the bounds' centre to the eye; need not be
// unit length) instead of the default front-right-above direction.
Camera frameBounds(const Bounds& bounds, const glm::vec3& towardsEye, float fovYDegrees,
                   float aspect);

}  // namespace myriad::scene
