#include "bench/bench_scene.h"

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "scene/builtin_scene.h"
#include "scene/light_generator.h"
#include "scene/model_loader.h"
#include "scene/primitives.h"

namespace myriad::bench {

namespace {

// Floor layout, in metres. The camera stands at z = 10 looking down towards the middle; the floor
// reaches past every edge of a 16:9 view so the whole picture is geometry. Lights fill a 60 x 40 m
// patch from beyond the top of the view to under the camera; those outside the view are culled,
// as in a real level, and a thin band at the far edge is lit by the sun alone.
constexpr float kFloorHalf = 45.0f;
constexpr float kLightsHalfX = 30.0f;
constexpr float kLightsFarZ = -30.0f;
constexpr float kLightsNearZ = 10.0f;
constexpr float kLightLow = 0.05f;
constexpr float kLightHigh = 1.2f;

// Lights per floor point: a light at height y < r reaches a floor point within the disc it
// touches, so the expected count is density x the half-ball volume (2/3) pi r^3. With radii
// uniform in [0.5, 1.5] x reach, E[r^3] = 1.25 reach^3. Exact only while reach is below the slab
// height; above it fewer reach the floor. The benchmark measures the true count anyway.
float reachFor(uint32_t count, float lightsPerPoint) {
  const float area = 2.0f * kLightsHalfX * (kLightsNearZ - kLightsFarZ);
  const float slab = kLightHigh - kLightLow;
  const float halfBallPerReachCubed = (2.0f / 3.0f) * 3.14159265f * 1.25f;
  return std::cbrt(lightsPerPoint * area * slab / (halfBallPerReachCubed * float(count)));
}

scene::Scene makeFloor(const BenchSceneSpec& spec) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(2.0f * kFloorHalf));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.55f), 0.0f, 0.7f});
  s.materials.push_back({"box", glm::vec3(0.8f, 0.5f, 0.3f), 0.5f, 0.35f});
  s.instances.push_back(
      {0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(2.0f * kFloorHalf, 1.0f, 2.0f * kFloorHalf))});
  // Boxes break the depth of many tiles (a tile straddling a box edge spans box and floor), which
  // is where tile and cluster culling earn or lose their keep.
  for (int row = 0; row < 3; ++row) {
    for (int column = 0; column < 5; ++column) {
      glm::vec3 at(-12.0f + 6.0f * float(column), 0.75f, -12.0f + 7.0f * float(row));
      glm::mat4 t = glm::translate(glm::mat4(1.0f), at);
      t = glm::rotate(t, glm::radians(17.0f * float(row * 5 + column)), glm::vec3(0, 1, 0));
      s.instances.push_back({1, 1, glm::scale(t, glm::vec3(1.5f))});
    }
  }
  s.sun.intensity = 0.3f;

  scene::LightGeneration g;
  g.count = spec.lightCount;
  g.seed = spec.seed;
  g.bounds.min = glm::vec3(-kLightsHalfX, kLightLow, kLightsFarZ);
  g.bounds.max = glm::vec3(kLightsHalfX, kLightHigh, kLightsNearZ);
  const float reach = spec.lightCount == 0 ? 1.0f : reachFor(spec.lightCount, spec.lightsPerPoint);
  g.minRadius = 0.5f * reach;
  g.maxRadius = 1.5f * reach;
  g.minIntensity = 1.0f;
  g.maxIntensity = 3.0f;
  s.lights = scene::generateLights(g);

  s.camera.eye = glm::vec3(0.0f, 8.0f, 10.0f);
  s.camera.target = glm::vec3(0.0f, 0.0f, -2.0f);
  s.camera.fovYDegrees = 50.0f;
  s.camera.nearPlane = 0.1f;
  s.camera.farPlane = 100.0f;
  return s;
}

}  // namespace

std::string_view benchSceneName(BenchScene scene) {
  switch (scene) {
    case BenchScene::Builtin:
      return "builtin";
    case BenchScene::Model:
      return "model";
    case BenchScene::Floor:
      break;
  }
  return "floor";
}

std::optional<BenchScene> parseBenchScene(std::string_view name) {
  if (name == "floor") return BenchScene::Floor;
  if (name == "builtin") return BenchScene::Builtin;
  return std::nullopt;
}

scene::Scene makeModelScene(const BenchSceneSpec& spec) {
  scene::Scene s = scene::loadModel(spec.modelPath);
  if (!spec.textures) {
    for (scene::Material& m : s.materials) {
      for (scene::TextureRef* ref : {&m.baseColorTexture, &m.metallicRoughnessTexture,
                                     &m.normalTexture, &m.occlusionTexture, &m.emissiveTexture}) {
        *ref = scene::TextureRef{};
      }
    }
    s.images.clear();
  }
  const scene::Bounds bounds = s.bounds();
  const float diagonal = glm::length(bounds.size());
  scene::LightGeneration lights;
  lights.count = spec.lightCount;
  lights.seed = spec.seed;
  lights.bounds.extend(bounds.min - glm::vec3(0.25f * diagonal));
  lights.bounds.extend(bounds.max + glm::vec3(0.25f * diagonal));
  lights.minRadius = 0.1f * diagonal;
  lights.maxRadius = 0.3f * diagonal;
  s.lights = scene::generateLights(lights);
  return s;
}

void addShadowedLights(scene::Scene& scene, uint32_t count, bool spots) {
  if (count == 0) return;
  const scene::Bounds bounds = scene.bounds();
  const glm::vec3 lo = bounds.empty() ? glm::vec3(-1.0f) : bounds.min;
  const glm::vec3 hi = bounds.empty() ? glm::vec3(1.0f) : bounds.max;
  const float diagonal = glm::length(hi - lo);
  const uint32_t across = uint32_t(std::ceil(std::sqrt(double(count))));
  for (uint32_t i = 0; i < count; ++i) {
    const float u = (float(i % across) + 0.5f) / float(across);
    const float v = (float(i / across) + 0.5f) / float(across);
    scene::PointLight l;
    l.position = glm::vec3(lo.x + u * (hi.x - lo.x), hi.y + 0.2f * diagonal, lo.z + v * (hi.z - lo.z));
    l.radius = 0.6f * diagonal;
    l.color = glm::vec3(1.0f, 0.95f, 0.85f);
    l.intensity = 2.0f;
    l.falloff = 1.0f;
    l.castsShadows = true;
    if (spots) {
      l.type = scene::LightType::Spot;
      l.direction = glm::vec3(0.0f, -1.0f, 0.0f);
      l.innerConeAngle = 0.5f;
      l.outerConeAngle = 0.6981317f;  // 40 degrees
    }
    scene.lights.push_back(l);
  }
}

scene::Scene makeBenchScene(const BenchSceneSpec& spec) {
  if (spec.kind == BenchScene::Builtin) return scene::makeBuiltinScene(spec.lightCount, spec.seed);
  if (spec.kind == BenchScene::Model) return makeModelScene(spec);
  return makeFloor(spec);
}

}  // namespace myriad::bench
