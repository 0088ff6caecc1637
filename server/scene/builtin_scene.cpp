#include "scene/builtin_scene.h"

#include <algorithm>
#include <cstdio>

#include <glm/gtc/matrix_transform.hpp>

#include "scene/camera.h"
#include "scene/light_generator.h"
#include "scene/primitives.h"

namespace myriad::scene {

namespace {

// Layout, in metres. The grid is the subject: columns sweep metallic 0..1 left to right, rows
// sweep roughness from mirror-like at the back to fully rough at the front, so a user can read
// the BRDF at a glance. Spacing leaves a gap of about a radius between spheres so that local lights
// fit between them and pools show on the floor around each one.
constexpr int kColumns = 7;
constexpr int kRows = 4;
constexpr float kSphereRadius = 0.45f;
constexpr float kSpacing = 1.3f;
constexpr float kFloorSize = 24.0f;

uint32_t addMaterial(Scene& scene, std::string name, glm::vec3 baseColor, float metallic,
                     float roughness) {
  scene.materials.push_back({std::move(name), baseColor, metallic, roughness});
  return uint32_t(scene.materials.size() - 1);
}

uint32_t addMesh(Scene& scene, Mesh mesh) {
  scene.meshes.push_back(std::move(mesh));
  return uint32_t(scene.meshes.size() - 1);
}

void place(Scene& scene, uint32_t mesh, uint32_t material, const glm::mat4& transform) {
  scene.instances.push_back({mesh, material, transform});
}

glm::mat4 trs(glm::vec3 translation, float yawDegrees, glm::vec3 scale) {
  glm::mat4 m = glm::translate(glm::mat4(1.0f), translation);
  m = glm::rotate(m, glm::radians(yawDegrees), glm::vec3(0.0f, 1.0f, 0.0f));
  return glm::scale(m, scale);
}

}  // namespace

LightGeneration builtinLightGeneration(uint32_t count, uint64_t seed) {
  // Tuned with a CPU preview of the design's BRDF at exposure 1. Low lights make tight bright spots
  // and high ones broad soft pools. The steep falloff (C = 16) keeps each light's energy near its
  // centre, so neighbouring pools stay distinct colours instead of summing to a pastel wash, and
  // the intensities keep them clearly brighter than the sun-lit floor.
  LightGeneration lights;
  lights.count = count;
  lights.seed = seed;
  const float half = 0.5f * kFloorSize;
  lights.bounds.min = {-half, 0.1f, -half};
  lights.bounds.max = {half, 1.5f, half};
  lights.minRadius = 1.0f;
  lights.maxRadius = 3.0f;
  lights.minIntensity = 1.5f;
  lights.maxIntensity = 4.0f;
  lights.falloff = 16.0f;
  lights.saturation = 0.9f;
  return lights;
}

Scene makeBuiltinScene(uint32_t lightCount, uint64_t seed) {
  Scene scene;
  const uint32_t sphere = addMesh(scene, makeSphere(64, 32));
  const uint32_t cube = addMesh(scene, makeCube());
  const uint32_t plane = addMesh(scene, makePlane(kFloorSize));
  const uint32_t gem = addMesh(scene, makeIcosphere(3));

  // A mid grey that is not quite neutral: light enough for coloured pools to read against it,
  // rough enough that they spread instead of mirroring each light as a spot.
  const uint32_t floor = addMaterial(scene, "floor", {0.3f, 0.3f, 0.32f}, 0.0f, 0.65f);
  place(scene, plane, floor, glm::scale(glm::mat4(1.0f), glm::vec3(kFloorSize, 1.0f, kFloorSize)));

  // One warm base colour across the grid so that only metallic and roughness vary between spheres:
  // dielectric it is a clay orange, metallic it becomes copper-gold.
  const glm::vec3 sphereColor(0.95f, 0.64f, 0.38f);
  const float roughnessByRow[kRows] = {0.05f, 0.3f, 0.6f, 1.0f};
  for (int row = 0; row < kRows; ++row) {
    for (int column = 0; column < kColumns; ++column) {
      const float metallic = float(column) / float(kColumns - 1);
      const float roughness = roughnessByRow[row];
      char name[48];
      std::snprintf(name, sizeof name, "sphere m%.2f r%.2f", metallic, roughness);
      const uint32_t material = addMaterial(scene, name, sphereColor, metallic, roughness);
      const glm::vec3 center((float(column) - 0.5f * float(kColumns - 1)) * kSpacing, kSphereRadius,
                             (float(row) - 0.5f * float(kRows - 1)) * kSpacing);
      place(scene, sphere, material, trs(center, 0.0f, glm::vec3(kSphereRadius)));
    }
  }

  // Shapes around the grid give the lights something vertical to fall on and the picture depth.
  const uint32_t stone = addMaterial(scene, "pillar", {0.42f, 0.44f, 0.5f}, 0.0f, 0.45f);
  for (float x : {-7.0f, -2.4f, 2.4f, 7.0f}) {
    place(scene, cube, stone, trs({x, 1.5f, -5.0f}, 0.0f, {0.7f, 3.0f, 0.7f}));
  }
  const uint32_t terracotta =
      addMaterial(scene, "terracotta block", {0.72f, 0.28f, 0.16f}, 0.0f, 0.55f);
  place(scene, cube, terracotta, trs({-5.8f, 0.6f, 1.2f}, 30.0f, glm::vec3(1.2f)));
  place(scene, cube, terracotta, trs({-5.7f, 1.55f, 1.1f}, 55.0f, glm::vec3(0.7f)));
  const uint32_t chrome = addMaterial(scene, "chrome", {0.95f, 0.95f, 0.97f}, 1.0f, 0.12f);
  place(scene, cube, stone, trs({5.5f, 0.35f, -0.4f}, -20.0f, {1.4f, 0.7f, 1.4f}));
  place(scene, gem, chrome, trs({5.5f, 1.5f, -0.4f}, 0.0f, glm::vec3(0.8f)));

  // Low and warm, from the front-left, so the spheres show a terminator to the camera; moderate so
  // that it models the shapes without drowning the local lights.
  scene.sun.direction = glm::normalize(glm::vec3(0.55f, -0.27f, -0.72f));
  scene.sun.color = {1.0f, 0.86f, 0.68f};
  scene.sun.intensity = 1.6f;
  scene.ambient = {0.020f, 0.024f, 0.032f};
  scene.background = {0.015f, 0.018f, 0.026f};

  scene.lights = generateLights(builtinLightGeneration(lightCount, seed));

  // Frame the sphere grid, not the whole floor (which would leave the grid a strip in the middle
  // distance), from a little above so the floor and its pools fill the lower half of the picture.
  Bounds grid;
  for (const Instance& instance : scene.instances) {
    if (instance.mesh == sphere) {
      for (const Vertex& v : scene.meshes[sphere].vertices) {
        grid.extend(glm::vec3(instance.transform * glm::vec4(v.position, 1.0f)));
      }
    }
  }
  scene.camera = frameBounds(grid, glm::vec3(0.3f, 0.42f, 1.0f), 50.0f, 16.0f / 9.0f);
  // A bounding sphere is loose around a flat grid; at 0.72 of its distance the grid fills about
  // three quarters of a 16:9 picture (the tests check that every sphere stays whole).
  scene.camera.eye = glm::mix(scene.camera.target, scene.camera.eye, 0.72f);
  // The floor reaches behind and beyond the framed grid: near must clear the floor under the eye
  // and far must reach the floor's far corners.
  scene.camera.nearPlane = 0.1f;
  const float half = 0.5f * kFloorSize;
  float farthest = 0.0f;
  for (float x : {-half, half}) {
    for (float z : {-half, half}) {
      farthest = std::max(farthest, glm::length(scene.camera.eye - glm::vec3(x, 0.0f, z)));
    }
  }
  scene.camera.farPlane = farthest * 1.05f;
  return scene;
}

}  // namespace myriad::scene
