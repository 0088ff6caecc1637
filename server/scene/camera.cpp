#include "scene/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace myriad::scene {

namespace {

// Front-right-above: enough side-on to show depth, high enough to see the top of a model.
const glm::vec3 kDefaultTowardsEye{1.0f, 0.6f, 1.4f};

// The bounding sphere's projection stays this far inside the narrower half-angle of the frustum.
constexpr float kFrameMargin = 1.1f;

bool isFinite(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

glm::mat4 viewMatrix(const Camera& camera) {
  // Cameras come in over the API, so an eye on the target or a view along `up` must still give a
  // usable matrix rather than NaNs that poison every pixel.
  glm::vec3 forward = camera.target - camera.eye;
  if (!isFinite(forward) || glm::length(forward) < 1e-12f) forward = glm::vec3(0.0f, 0.0f, -1.0f);
  forward = glm::normalize(forward);
  glm::vec3 up = isFinite(camera.up) && glm::length(camera.up) > 1e-12f ? glm::normalize(camera.up)
                                                                        : glm::vec3(0, 1, 0);
  if (std::abs(glm::dot(forward, up)) > 0.9999f) {
    up = std::abs(forward.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
  }
  return glm::lookAtRH(camera.eye, camera.eye + forward, up);
}

glm::mat4 projectionMatrix(const Camera& camera, float aspect) {
  const float fovY = glm::radians(std::clamp(camera.fovYDegrees, 1.0f, 179.0f));
  const float safeAspect = std::isfinite(aspect) && aspect > 1e-6f ? aspect : 1.0f;
  const float nearPlane = std::max(camera.nearPlane, 1e-6f);
  const float farPlane = std::max(camera.farPlane, nearPlane * 1.001f);
  glm::mat4 projection = glm::perspectiveRH_ZO(fovY, safeAspect, nearPlane, farPlane);
  // Vulkan's framebuffer y points down; flipping here keeps +y up in the world and the image
  // upright.
  projection[1][1] *= -1.0f;
  return projection;
}

Intrinsics intrinsicsOf(const Camera& camera, uint32_t width, uint32_t height) {
  // projectionMatrix's field of view, clamped the same way.
  const float fovY = glm::radians(std::clamp(camera.fovYDegrees, 1.0f, 179.0f));
  const float focal = 0.5f * float(height) / std::tan(0.5f * fovY);
  return {focal, focal, 0.5f * float(width), 0.5f * float(height)};
}

glm::mat4 worldFromCamera(const Camera& camera) {
  // The view matrix looks down -Z with +Y up (OpenGL's axes); OpenCV's flip Y and Z.
  return glm::inverse(viewMatrix(camera)) *
         glm::mat4(glm::vec4(1, 0, 0, 0), glm::vec4(0, -1, 0, 0), glm::vec4(0, 0, -1, 0),
                   glm::vec4(0, 0, 0, 1));
}

Camera frameBounds(const Bounds& bounds, float fovYDegrees, float aspect) {
  return frameBounds(bounds, kDefaultTowardsEye, fovYDegrees, aspect);
}

Camera frameBounds(const Bounds& bounds, const glm::vec3& towardsEye, float fovYDegrees,
                   float aspect) {
  glm::vec3 center(0.0f);
  float radius = 1.0f;
  if (!bounds.empty() && isFinite(bounds.min) && isFinite(bounds.max)) {
    center = bounds.center();
    radius = 0.5f * glm::length(bounds.size());
    // A single point (or a flat, zero-area thing seen edge-on) still needs a nonzero distance;
    // scale the floor with the coordinates so it survives float precision far from the origin.
    const float magnitude = std::max({std::abs(center.x), std::abs(center.y), std::abs(center.z)});
    radius = std::max(radius, 1e-4f * std::max(1.0f, magnitude));
    if (!std::isfinite(radius) || !isFinite(center)) {
      center = glm::vec3(0.0f);
      radius = 1.0f;
    }
  }

  Camera camera;
  camera.fovYDegrees = std::clamp(std::isfinite(fovYDegrees) ? fovYDegrees : 50.0f, 1.0f, 179.0f);
  const float safeAspect = std::isfinite(aspect) && aspect > 1e-6f ? aspect : 1.0f;
  const float halfFovY = 0.5f * glm::radians(camera.fovYDegrees);
  const float halfFovX = std::atan(std::tan(halfFovY) * safeAspect);
  const float halfFov = std::min(halfFovY, halfFovX);
  const float distance = kFrameMargin * radius / std::sin(halfFov);

  glm::vec3 direction = isFinite(towardsEye) && glm::length(towardsEye) > 1e-12f
                            ? glm::normalize(towardsEye)
                            : glm::normalize(kDefaultTowardsEye);
  camera.target = center;
  camera.eye = center + direction * distance;
  camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
  // The nearest point of the bounds is at distance - radius; keep the near plane in front of that
  // but as far out as possible, since depth precision is set mostly by the near plane.
  camera.nearPlane = std::max(distance - 1.5f * radius, distance * 0.002f);
  camera.farPlane = distance + 2.0f * radius;
  return camera;
}

}  // namespace myriad::scene
