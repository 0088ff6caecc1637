#pragma once

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace myriad::scene {

// Right-handed view matrix looking from camera.eye at camera.target.
glm::mat4 viewMatrix(const Camera& camera);

// Vulkan clip space: depth 0 at the near plane, 1 at the far plane, +y down in the image.
glm::mat4 projectionMatrix(const Camera& camera, float aspect);

// The pinhole intrinsics of a frame of `width` x `height` pixels through `camera`, in OpenCV's
// convention: a point at (x, y, z) in camera space (x right, y down, z forward: worldFromCamera's
// axes) lands at pixel coordinates u = fx x / z + cx, v = fy y / z + cy, where (0, 0) is the
// top-left corner of the top-left pixel (its centre is (0.5, 0.5)). The same projection as
// projectionMatrix at aspect width / height (square pixels: fx = fy).
struct Intrinsics {
  float fx = 0.0f, fy = 0.0f, cx = 0.0f, cy = 0.0f;
};
Intrinsics intrinsicsOf(const Camera& camera, uint32_t width, uint32_t height);

// The camera's pose: the matrix taking camera-space points (OpenCV axes: x right, y down, z
// forward) to world space. Its translation is the eye.
glm::mat4 worldFromCamera(const Camera& camera);

// A camera that sees all of `bounds` at the given vertical field of view and aspect ratio, looking
// from the front-right and above; near/far enclose the bounds with margin.
Camera frameBounds(const Bounds& bounds, float fovYDegrees = 50.0f, float aspect = 16.0f / 9.0f);

// As above, with the eye placed along `towardsEye` (from the bounds' centre to the eye; need not be
// unit length) instead of the default front-right-above direction.
Camera frameBounds(const Bounds& bounds, const glm::vec3& towardsEye, float fovYDegrees,
                   float aspect);

}  // namespace myriad::scene
