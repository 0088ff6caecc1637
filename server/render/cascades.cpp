// The sun's shadow maps fitted: one over the scene (fitSunShadow) or cascades over the view
// (fitSunCascades). render/shadows.h says how.
#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>

#include "render/shadows.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// The scene's bounding sphere, snapped outwards to a grid of a 32nd of its radius (a power of
// two): an object moved a little past the bounds leaves it, and so the maps, as they were
// (ShadowMaps::repairSun redraws only under it), for at most ~10% fewer texels a metre. A
// function of the bounds alone: the same scene always gets the same sphere.
struct Sphere {
  glm::vec3 center;
  float radius;
};
Sphere sceneSphere(const scene::Bounds& bounds) {
  const glm::vec3 lo = bounds.empty() ? glm::vec3(-1.0f) : bounds.min;
  const glm::vec3 hi = bounds.empty() ? glm::vec3(1.0f) : bounds.max;
  const glm::vec3 exactCenter = 0.5f * (lo + hi);
  const float exactRadius = std::max(0.5f * glm::length(hi - lo), 1e-3f);
  const float step = std::exp2(std::ceil(std::log2(exactRadius / 32.0f)));
  const glm::vec3 center = glm::round(exactCenter / step) * step;
  const float radius = std::ceil((exactRadius + glm::length(exactCenter - center)) / step) * step;
  return {center, radius};
}

glm::vec3 upFor(glm::vec3 d) {
  return std::abs(d.y) > 0.99f ? glm::vec3(0.0f, 0.0f, 1.0f) : glm::vec3(0.0f, 1.0f, 0.0f);
}

// Clip x, y in [-1, 1] -> u, v in [0, 1] (clip y = -1 is the map's first row, v = 0); depth as is.
glm::mat4 uvFromClip() {
  return glm::translate(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, 0.0f)) *
         glm::scale(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, 1.0f));
}

}  // namespace

glm::uvec2 sunAtlasGrid(uint32_t cascades) {
  return {std::min(cascades, 2u), (cascades + 1) / 2};
}

VkExtent2D SunShadowFit::atlas() const {
  const glm::uvec2 grid = sunAtlasGrid(cascades);
  return {grid.x * tileSize, grid.y * tileSize};
}

bool SunShadowFit::sameMaps(const SunShadowFit& other) const {
  if (cascades != other.cascades || tileSize != other.tileSize) return false;
  for (uint32_t c = 0; c < cascades; ++c) {
    if (viewProjection[c] != other.viewProjection[c]) return false;
  }
  return true;
}

SunShadowFit fitSunShadow(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size) {
  // The bounds' sphere: its square, seen from any direction, holds the whole scene, so the fit
  // depends on the scene and the sun only.
  const Sphere sphere = sceneSphere(bounds);
  const glm::vec3 d = glm::normalize(direction);
  // A little beyond the sphere so nothing touches the near or far plane.
  const float reach = sphere.radius * 1.01f;
  const glm::mat4 view = glm::lookAt(sphere.center - d * reach, sphere.center, upFor(d));
  const glm::mat4 projection = glm::orthoRH_ZO(-reach, reach, -reach, reach, 0.0f, 2.0f * reach);
  SunShadowFit fit;
  fit.cascades = 1;
  fit.tileSize = size;
  fit.viewProjection[0] = projection * view;
  fit.mapFromWorld[0] = uvFromClip() * fit.viewProjection[0];
  fit.texelWorld[0] = 2.0f * reach / float(size);
  fit.depthTexel[0] = 1.0f / float(size);  // the depth range is as deep as the map is wide
  fit.splitFar[0] = std::numeric_limits<float>::max();
  return fit;
}

SunShadowFit fitSunCascades(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size,
                            uint32_t cascades, const scene::Camera& camera, float aspect,
                            bool snap) {
  cascades = std::clamp(cascades, 1u, kMaxSunCascades);
  if (cascades == 1) return fitSunShadow(bounds, direction, size);
  const Sphere scene = sceneSphere(bounds);
  const glm::vec3 d = glm::normalize(direction);
  // The light's space, about the world's origin: x, y across the maps, -z along the sun.
  const glm::mat4 lightView = glm::lookAt(glm::vec3(0.0f), d, upFor(d));
  // Every map's depth holds the scene's sphere along the sun, with a margin.
  const float sceneDepth = glm::dot(scene.center, d);
  const float zNear = sceneDepth - scene.radius * 1.01f;
  const float zFar = sceneDepth + scene.radius * 1.01f;

  // The view's depth clamped to the scene's sphere, rounded outwards to a quarter of its radius so
  // that a camera moving a little keeps the same splits (and so the same texel sizes).
  const float step = scene.radius * 0.25f;
  const float distance = glm::length(scene.center - camera.eye);
  const float near = std::max(camera.nearPlane, std::floor((distance - scene.radius) / step) * step);
  const float far = std::max(std::min(camera.farPlane, std::ceil((distance + scene.radius) / step) * step),
                             near * 1.01f);
  const float tanY = std::tan(glm::radians(camera.fovYDegrees) * 0.5f);
  const float k2 = tanY * tanY * (1.0f + aspect * aspect);  // (a frustum corner's offset / depth)^2
  const glm::vec3 forward = glm::normalize(camera.target - camera.eye);

  SunShadowFit fit;
  fit.cascades = cascades;
  fit.tileSize = size;
  float sliceNear = near;
  for (uint32_t c = 0; c < cascades; ++c) {
    const float t = float(c + 1) / float(cascades);
    const float sliceFar = c + 1 == cascades
                               ? far
                               : kCascadeLambda * near * std::pow(far / near, t) +
                                     (1.0f - kCascadeLambda) * (near + (far - near) * t);
    // The slice's bounding sphere: its centre on the view axis where the near and far corners are
    // equally far, or at the far plane's centre when that lies beyond it.
    const float centerDepth = std::min(0.5f * (sliceNear + sliceFar) * (1.0f + k2), sliceFar);
    const float radius = std::sqrt((sliceFar - centerDepth) * (sliceFar - centerDepth) +
                                   sliceFar * sliceFar * k2);
    // The square holds the sphere with two texels to spare on each side: the snap below moves it
    // by up to one, and the lookup keeps a texel from the tile's border (frame.glsl).
    const float texel = 2.0f * radius / float(size - 4);
    const float half = 0.5f * texel * float(size);
    glm::vec2 center = glm::vec2(lightView * glm::vec4(camera.eye + forward * centerDepth, 1.0f));
    // Whole texels of the light's space: the map moves only by whole texels.
    if (snap) center = glm::floor(center / texel) * texel;
    // glm::orthoRH_ZO(center.x - half, center.x + half, ...) written out, so that its scale does
    // not pick up the rounding of (center + half) - (center - half): two fits with the same
    // splits then differ in the translation alone, by whole texels (ShadowMaps::scrollSun).
    glm::mat4 projection(1.0f);
    projection[0][0] = 1.0f / half;
    projection[1][1] = 1.0f / half;
    projection[2][2] = -1.0f / (zFar - zNear);
    projection[3][0] = -center.x / half;
    projection[3][1] = -center.y / half;
    projection[3][2] = -zNear / (zFar - zNear);
    fit.viewProjection[c] = projection * lightView;
    fit.mapFromWorld[c] = uvFromClip() * fit.viewProjection[c];
    fit.texelWorld[c] = texel;
    fit.depthTexel[c] = texel / (zFar - zNear);
    fit.splitFar[c] = c + 1 == cascades ? std::numeric_limits<float>::max() : sliceFar;
    sliceNear = sliceFar;
  }
  return fit;
}

}  // namespace myriad::render
