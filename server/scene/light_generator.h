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

// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good Algorithms
// for Random Number Generation"), XSH-RR output on a 64-bit LCG. Ours rather than <random> because
// the standard fixes the engines' sequences but not what its distributions make of them, and light
// layouts must match on every platform for tests and shared links to agree. Public so tests can
// check it against the reference sequence.
class Pcg32 {
 public:
  // `stream` picks one of 2^63 independent sequences; `seed` the starting point in it.
  Pcg32(uint64_t seed, uint64_t stream);
  uint32_t next();
  // Uniform in [0, 1).
  float unit();
  // Uniform in [low, high].
  float uniform(float low, float high);

 private:
  uint64_t state_ = 0;
  uint64_t increment_;
};

// Deterministic for a given LightGeneration on every platform (own PCG32, no std distributions).
std::vector<PointLight> generateLights(const LightGeneration& params);

}  // namespace myriad::scene
