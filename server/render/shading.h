// The C++ twin of the shaders' shading model: the same source file (shaders/shading.glsl),
// compiled as C++ with GLM standing in for GLSL's built-ins. The tests' reference images use it.
#pragma once

#include <glm/glm.hpp>

#include "shared_types.h"

#include <cmath>
#include <limits>

namespace myriad::shading {
using namespace glm;

// GLSL's pow(x, y) is undefined for x < 0, and for x == 0 with y <= 0 (GLSL 4.50, 8.2): GPUs give
// NaN there, while std::pow of a negative base and a whole exponent is a number. The twin gives
// NaN too, so the reference fails where a GPU would rather than hiding the fault. Declared here,
// it hides glm::pow inside shading.glsl.
inline float pow(float x, float y) {
  if (x < 0.0f || (x == 0.0f && y <= 0.0f)) return std::numeric_limits<float>::quiet_NaN();
  return std::pow(x, y);
}

#include "shading.glsl"

// The environment light's arrays for environment.glsl's functions (see its header): whoever runs
// them in C++ (the reference) points these at its own maps first, on its own thread.
struct EnvironmentArrays {
  const glm::vec4* source = nullptr;    // MYRIAD_ENV_SOURCE_TEXELS
  const glm::vec4* lighting = nullptr;  // MYRIAD_ENV_HEADER + the specular levels
  const glm::vec4* lut = nullptr;       // MYRIAD_BRDF_LUT_SIZE^2
};
inline thread_local EnvironmentArrays environmentArrays;
#define MYRIAD_ENV_SOURCE(i) environmentArrays.source[i]
#define MYRIAD_ENV_LIGHTING(i) environmentArrays.lighting[i]
#define MYRIAD_BRDF_LUT(i) environmentArrays.lut[i]
#include "environment.glsl"
#undef MYRIAD_ENV_SOURCE
#undef MYRIAD_ENV_LIGHTING
#undef MYRIAD_BRDF_LUT
}  // namespace myriad::shading
