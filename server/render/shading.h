// The C++ twin of the shaders' shading model: the same source file (shaders/shading.glsl),
// compiled as C++ with GLM standing in for GLSL's built-ins. The tests' reference images use it.
#pragma once

#include <glm/glm.hpp>

namespace myriad::shading {
using namespace glm;
#include "shading.glsl"
}  // namespace myriad::shading
