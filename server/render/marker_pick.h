// Which light's marker a frame draws under a pixel, on the CPU: the service answers
// GET .../lights/pick with it, for any of a session's lights (a page knows only a page of them).
// It follows the marker passes exactly (shaders/marker_splat.comp, markers.glsl): the same share
// of lights keeps a marker (the same hash of the light's slot), the same pixel radius from the
// light count and frame size, the same projection. Two things a CPU cannot see are left out: the
// G-buffer depth test (a marker hidden behind geometry can still be picked when nothing visible
// is nearer the pixel) and animation (lights are taken where the session holds them).
// Header only: the service links the renderer's plain headers, not its library.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>

#include <glm/glm.hpp>

#include "scene/camera.h"
#include "scene/scene.h"
#include "shaders/markers.h"

namespace myriad::render {

// marker_splat.comp's markerHash (a PCG-style integer hash, Jarzynski & Olano, JCGT 2020) ->
// [0, 1), computed as the shader does (32-bit unsigned arithmetic, then float).
inline float markerHash(uint32_t v) {
  uint32_t state = v * 747796405u + 2891336453u;
  uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return float((word >> 22u) ^ word) / 4294967296.0f;
}

struct MarkerLayout {
  float radius = 0.0f;  // pixels; below MYRIAD_MARKER_MIN_RADIUS a marker is one pixel
  float keep = 1.0f;    // share of the lights that get a marker
};

// markers.glsl's markerRadius() and markerKeep() for `lightCount` lights in a width x height frame.
inline MarkerLayout markerLayout(uint32_t lightCount, uint32_t width, uint32_t height) {
  const float budget = float(MYRIAD_MARKER_COVERAGE) * float(width) * float(height);
  const float n = std::max(float(lightCount), 1.0f);
  return {std::min(std::sqrt(budget / (3.14159265f * n)), float(MYRIAD_MARKER_MAX_RADIUS)),
          std::min(1.0f, budget / n)};
}

struct MarkerHit {
  uint32_t slot = 0;       // the light's index in the scene's light array
  float distance = 0.0f;   // pixels from the pixel's centre to the marker's centre
  uint32_t candidates = 0; // markers within reach
};

// The marker under pixel (x, y) of a width x height frame (y down) of `camera`, or within `reach`
// more pixels of it: the nearest marker centre, then the one nearer the eye. nullopt when none.
inline std::optional<MarkerHit> pickMarker(std::span<const scene::PointLight> lights,
                                           const scene::Camera& camera, uint32_t width,
                                           uint32_t height, double x, double y, float reach) {
  const glm::mat4 viewProjection = scene::projectionMatrix(camera, float(width) / float(height)) *
                                   scene::viewMatrix(camera);
  const MarkerLayout layout = markerLayout(uint32_t(lights.size()), width, height);
  const bool onePixel = layout.radius < float(MYRIAD_MARKER_MIN_RADIUS);
  // A one-pixel marker covers the pixel that holds its centre: within half a diagonal.
  const float size = onePixel ? 0.7072f : layout.radius;
  const glm::vec2 pixel(std::floor(float(x)) + 0.5f, std::floor(float(y)) + 0.5f);
  std::optional<MarkerHit> best;
  float bestRank = 0.0f;  // 0 for a one-pixel marker on the pixel itself, else the distance
  float bestDepth = 0.0f;
  uint32_t candidates = 0;
  for (uint32_t i = 0; i < lights.size(); ++i) {
    if (markerHash(i) >= layout.keep) continue;
    const glm::vec4 clip = viewProjection * glm::vec4(lights[i].position, 1.0f);
    if (clip.w <= 0.0f) continue;
    const glm::vec3 ndc = glm::vec3(clip) / clip.w;
    if (ndc.z < 0.0f || ndc.z > 1.0f || std::abs(ndc.x) > 1.01f || std::abs(ndc.y) > 1.01f) continue;
    const glm::vec2 centre = (glm::vec2(ndc) * 0.5f + 0.5f) * glm::vec2(width, height);
    bool covers = false;
    if (onePixel) {
      covers = std::floor(centre.x) == std::floor(float(x)) && std::floor(centre.y) == std::floor(float(y));
    }
    const float distance = glm::length(centre - pixel);
    if (!covers && distance > size + reach) continue;
    ++candidates;
    const float rank = covers ? 0.0f : distance;
    if (!best || rank < bestRank - 1e-3f ||
        (std::abs(rank - bestRank) <= 1e-3f && ndc.z < bestDepth)) {
      best = MarkerHit{i, distance, 0};
      bestRank = rank;
      bestDepth = ndc.z;
    }
  }
  if (best) best->candidates = candidates;
  return best;
}

}  // namespace myriad::render
