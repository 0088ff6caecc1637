#pragma once

#include <cstdint>

#include "scene/scene.h"

namespace myriad::scene {

// The first picture a user sees: a floor, a grid of spheres spanning metallic (columns) x
// roughness (rows), a few other shapes, a sun, and `lightCount` local lights of varied colours
// and radii placed deterministically from `seed` just above the floor.
Scene makeBuiltinScene(uint32_t lightCount = 256, uint64_t seed = 1);

}  // namespace myriad::scene
