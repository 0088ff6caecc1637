#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace myriad::scene {

struct LightGeneration {
  uint32_t count = 0;
  uint64_t seed = 1;
  Bounds bounds;                 // light positions are uniform in these bounds
  float minRadius = 0.5f;
  float maxRadius = 2.0f;
  float minIntensity = 1.0f;
  float maxIntensity = 4.0f;
  float falloff = 1.0f;          // the attenuation constant C of every light
  float saturation = 0.8f;       // colours: random hue, this saturation, value 1
};

// Deterministic for a given LightGeneration on every platform (own PCG32, no std distributions).
std::vector<PointLight> generateLights(const LightGeneration& params);

}  // namespace myriad::scene
