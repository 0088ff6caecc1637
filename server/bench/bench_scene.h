// The scenes the benchmark renders, each with the camera it is measured from.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "scene/scene.h"

namespace myriad::bench {

enum class BenchScene {
  // A wide floor with a few boxes, seen from above at a slant so geometry fills the picture. Light
  // radii shrink as the count grows so that about the same number of lights reaches each point of
  // the floor: the cost of light count alone, not of ever denser light.
  Floor,
  // The server's built-in scene (server/scene/builtin_scene.h) with its own light radii: the
  // density of light grows with the count (about 0.026 lights per point per light).
  Builtin,
  // A model file (--model PATH: glTF, OBJ, ... loaded in this process; the benchmark is a trusted
  // tool) seen from its own framing camera, with lights scattered around it (radii 10-30% of its
  // diagonal). --textures off strips every texture, so the same geometry is measured with its
  // materials' factors alone: the difference is what texturing costs.
  Model,
};

std::string_view benchSceneName(BenchScene scene);
std::optional<BenchScene> parseBenchScene(std::string_view name);

struct BenchSceneSpec {
  BenchScene kind = BenchScene::Floor;
  uint32_t lightCount = 0;
  uint64_t seed = 1;
  float lightsPerPoint = 64.0f;  // Floor: the mean number of lights meant to reach a floor point
  std::string modelPath;         // Model
  bool textures = true;          // Model: false strips every texture (factors only)
};

// The scene, with scene.camera the view the benchmark renders.
scene::Scene makeBenchScene(const BenchSceneSpec& spec);

// Appends `count` lights asking for shadows (--shadowed-lights): on a grid over the scene's
// bounds, a fifth of its diagonal above its top, each reaching 60% of the diagonal (so each map
// holds most of the scene); spot lights (`spots`) point down with a 40-degree cone, point lights
// get a cube. They come after the scene's own lights, which keep their indices.
void addShadowedLights(scene::Scene& scene, uint32_t count, bool spots);

}  // namespace myriad::bench
