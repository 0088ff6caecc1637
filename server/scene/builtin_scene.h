#pragma once

#include <cstdint>

#include "scene/light_generator.h"
#include "scene/scene.h"

namespace myriad::scene {

// The first picture a user sees: a floor, a grid of spheres spanning metallic (columns) x
// roughness (rows), a few other shapes, a sun, and `lightCount` local lights of varied colours
// and radii placed deterministically from `seed` just above the floor.
Scene makeBuiltinScene(uint32_t lightCount = 256, uint64_t seed = 1);

// How the built-in scene's lights are made: `count` from `seed`, just above its floor. What
// makeBuiltinScene uses, and what the service generates for the built-in model when a request or
// a snapshot names only a count and a seed (service/startup.h defaultLightGeneration).
LightGeneration builtinLightGeneration(uint32_t count, uint64_t seed);

}  // namespace myriad::scene
