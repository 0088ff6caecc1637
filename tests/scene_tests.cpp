// The scene module on the CPU: procedural meshes, the light generator, cameras, the built-in scene
// and model loading (including every OBJ and glTF model of Debian's assimp-testmodels).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <glm/gtc/matrix_transform.hpp>

#include "scene/builtin_scene.h"
#include "scene/camera.h"
#include "scene/environment_map.h"
#include "scene/light_generator.h"
#include "scene/model_loader.h"
#include "scene/primitives.h"

using namespace myriad::scene;
namespace fs = std::filesystem;

namespace {

const fs::path kModels = "/usr/share/assimp/models";

bool finite(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Indices in range, unit normals, and every triangle wound counter-clockwise seen from the side
// its normals face (the geometric normal agrees with the average vertex normal).
void checkMeshWellFormed(const Mesh& mesh) {
  REQUIRE(mesh.indices.size() % 3 == 0);
  REQUIRE(std::all_of(mesh.indices.begin(), mesh.indices.end(),
                      [&](uint32_t i) { return i < mesh.vertices.size(); }));
  size_t badVertices = 0;
  for (const Vertex& v : mesh.vertices) {
    badVertices += !finite(v.position) || std::abs(glm::length(v.normal) - 1.0f) > 1e-5f;
  }
  CHECK(badVertices == 0);
  size_t degenerate = 0, misWound = 0;
  for (size_t t = 0; t < mesh.indices.size(); t += 3) {
    const Vertex& a = mesh.vertices[mesh.indices[t]];
    const Vertex& b = mesh.vertices[mesh.indices[t + 1]];
    const Vertex& c = mesh.vertices[mesh.indices[t + 2]];
    const glm::vec3 geometric = glm::cross(b.position - a.position, c.position - a.position);
    degenerate += !(glm::length(geometric) > 0.0f);
    misWound += glm::dot(geometric, a.normal + b.normal + c.normal) <= 0.0f;
  }
  CHECK(degenerate == 0);
  CHECK(misWound == 0);
}

// Each undirected edge used by exactly two triangles, once in each direction: closed and
// consistently oriented.
bool isClosedManifold(const Mesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < mesh.indices.size(); t += 3) {
    for (int k = 0; k < 3; ++k) {
      ++directed[{mesh.indices[t + k], mesh.indices[t + (k + 1) % 3]}];
    }
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

glm::vec3 toNdc(const Camera& camera, float aspect, const glm::vec3& world, float* w = nullptr) {
  const glm::vec4 clip =
      projectionMatrix(camera, aspect) * viewMatrix(camera) * glm::vec4(world, 1.0f);
  if (w != nullptr) *w = clip.w;
  return glm::vec3(clip) / clip.w;
}

bool insideFrustum(const Camera& camera, float aspect, const glm::vec3& world, float margin = 0) {
  float w = 0.0f;
  const glm::vec3 ndc = toNdc(camera, aspect, world, &w);
  const float limit = 1.0f - margin;
  return w > 0.0f && std::abs(ndc.x) <= limit && std::abs(ndc.y) <= limit && ndc.z > 0.0f &&
         ndc.z < 1.0f;
}

std::vector<glm::vec3> corners(const Bounds& b) {
  std::vector<glm::vec3> out;
  for (int i = 0; i < 8; ++i) {
    out.push_back(
        {i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y, i & 4 ? b.max.z : b.min.z});
  }
  return out;
}

Bounds box(glm::vec3 min, glm::vec3 max) {
  Bounds b;
  b.min = min;
  b.max = max;
  return b;
}

bool sameLights(const std::vector<PointLight>& a, const std::vector<PointLight>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].position != b[i].position || a[i].color != b[i].color || a[i].radius != b[i].radius ||
        a[i].intensity != b[i].intensity || a[i].falloff != b[i].falloff) {
      return false;
    }
  }
  return true;
}

}  // namespace

TEST_CASE("UV sphere: unit radius, outward normals, counter-clockwise, uvs in 0..1") {
  const Mesh sphere = makeSphere(48, 24);
  // (rings + 1) x (segments + 1) vertices; the two pole rings have one triangle per segment.
  CHECK(sphere.vertices.size() == 25 * 49);
  CHECK(sphere.indices.size() / 3 == 2 * 48 * 24 - 2 * 48);
  checkMeshWellFormed(sphere);
  for (const Vertex& v : sphere.vertices) {
    CHECK(glm::length(v.position) == doctest::Approx(1.0f).epsilon(1e-6));
    CHECK(glm::dot(v.normal, v.position) > 0.99f);
    CHECK(v.uv.x >= 0.0f);
    CHECK(v.uv.x <= 1.0f);
    CHECK(v.uv.y >= 0.0f);
    CHECK(v.uv.y <= 1.0f);
  }
  // Degenerate requests are raised to the smallest closed sphere rather than producing nothing.
  const Mesh tiny = makeSphere(0, 0);
  CHECK(tiny.indices.size() / 3 == 2 * 3 * 2 - 2 * 3);
  checkMeshWellFormed(tiny);
}

TEST_CASE("UV sphere LODs: the same vertices, fewer triangles, facing out, within their error") {
  const Mesh sphere = makeSphere(64, 32);
  REQUIRE(sphere.lods.size() == 3);  // 32x16, 16x8 and 8x4
  const size_t triangles[] = {2 * 32 * 16 - 2 * 32, 2 * 16 * 8 - 2 * 16, 2 * 8 * 4 - 2 * 8};
  float previousError = 0.0f;
  for (size_t l = 0; l < sphere.lods.size(); ++l) {
    CAPTURE(l);
    const MeshLod& lod = sphere.lods[l];
    CHECK(lod.indices.size() / 3 == triangles[l]);
    CHECK(lod.error > previousError);  // coarser each time
    previousError = lod.error;
    float deepest = 0.0f;
    for (size_t t = 0; t + 2 < lod.indices.size(); t += 3) {
      REQUIRE(lod.indices[t] < sphere.vertices.size());
      REQUIRE(lod.indices[t + 1] < sphere.vertices.size());
      REQUIRE(lod.indices[t + 2] < sphere.vertices.size());
      const glm::vec3 a = sphere.vertices[lod.indices[t]].position;
      const glm::vec3 b = sphere.vertices[lod.indices[t + 1]].position;
      const glm::vec3 c = sphere.vertices[lod.indices[t + 2]].position;
      const glm::vec3 n = glm::cross(b - a, c - a);
      CHECK(glm::length(n) > 0.0f);        // no pole triangles without area
      CHECK(glm::dot(n, a + b + c) > 0.0f);  // counter-clockwise seen from outside
      // The surface stays within `error` of the sphere (and so of the full mesh, which lies
      // between them): sampled on a barycentric grid.
      for (int i = 0; i <= 8; ++i) {
        for (int j = 0; i + j <= 8; ++j) {
          const glm::vec3 p = a + (b - a) * (float(i) / 8.0f) + (c - a) * (float(j) / 8.0f);
          deepest = std::max(deepest, 1.0f - glm::length(p));
        }
      }
    }
    CHECK(deepest <= lod.error + 1e-5f);
    CHECK(deepest >= 0.5f * lod.error);  // a bound, not a wild over-estimate
  }
  // Halved while at least 8 segments and 4 rings remain; odd counts have none.
  CHECK(makeSphere(48, 24).lods.size() == 2);  // 24x12, 12x6
  CHECK(makeSphere(16, 8).lods.size() == 1);
  CHECK(makeSphere(8, 4).lods.empty());
  CHECK(makeSphere(30, 15).lods.empty());
  CHECK(makeSphere(0, 0).lods.empty());
  CHECK(makeIcosphere(3).lods.empty());
}

TEST_CASE("coarsestLodWithin: the coarsest version whose error covers at most the pixels allowed") {
  const std::vector<float> errors = {0.01f, 0.04f};
  CHECK(coarsestLodWithin(errors, 10.0f, 0.5f) == 1);    // 0.1 and 0.4 pixels
  CHECK(coarsestLodWithin(errors, 20.0f, 0.5f) == 0);    // 0.2 and 0.8
  CHECK(coarsestLodWithin(errors, 100.0f, 0.5f) == -1);  // 1 and 4: the full mesh
  CHECK(coarsestLodWithin(errors, 10.0f, 0.0f) == -1);   // not allowed at all
  CHECK(coarsestLodWithin({}, 1.0f, 0.5f) == -1);
}

TEST_CASE("Icosphere: exactly on the unit sphere, watertight, 20 * 4^n faces") {
  for (uint32_t n = 0; n <= 4; ++n) {
    CAPTURE(n);
    const Mesh ico = makeIcosphere(n);
    const size_t faces = 20u << (2 * n);
    CHECK(ico.indices.size() / 3 == faces);
    CHECK(ico.vertices.size() == faces / 2 + 2);  // Euler: V - E + F = 2 with E = 3F / 2
    checkMeshWellFormed(ico);
    CHECK(isClosedManifold(ico));
    for (const Vertex& v : ico.vertices) {
      CHECK(glm::length(v.position) == doctest::Approx(1.0f).epsilon(1e-6));
      CHECK(glm::length(v.normal - v.position) < 1e-6f);
    }
  }
  // Capped, so a careless request cannot allocate gigabytes.
  CHECK(makeIcosphere(100).indices.size() == makeIcosphere(7).indices.size());
}

TEST_CASE("Plane and cube: flat normals, winding, uvs") {
  const Mesh plane = makePlane(4.0f);
  CHECK(plane.vertices.size() == 4);
  CHECK(plane.indices.size() == 6);
  checkMeshWellFormed(plane);
  for (const Vertex& v : plane.vertices) {
    CHECK(v.normal == glm::vec3(0, 1, 0));
    CHECK(v.position.y == 0.0f);
    CHECK(std::abs(v.position.x) == 0.5f);
    CHECK(std::abs(v.position.z) == 0.5f);
    CHECK((v.uv.x == 0.0f || v.uv.x == 4.0f));
    CHECK((v.uv.y == 0.0f || v.uv.y == 4.0f));
  }

  const Mesh cube = makeCube();
  CHECK(cube.vertices.size() == 24);
  CHECK(cube.indices.size() == 36);
  checkMeshWellFormed(cube);
  for (const Vertex& v : cube.vertices) {
    CHECK(glm::dot(v.normal, v.position) == doctest::Approx(0.5f));  // on its own face
    for (int axis = 0; axis < 3; ++axis) CHECK(std::abs(v.position[axis]) == 0.5f);
    CHECK(v.uv.x >= 0.0f);
    CHECK(v.uv.x <= 1.0f);
  }
  Scene scene;
  scene.meshes = {cube};
  scene.instances = {Instance{}};
  const Bounds bounds = scene.bounds();
  CHECK(bounds.min == glm::vec3(-0.5f));
  CHECK(bounds.max == glm::vec3(0.5f));
}

TEST_CASE("Scene bounds cover every transformed instance and ignore dangling ones") {
  Scene scene;
  CHECK(scene.bounds().empty());
  scene.meshes.push_back(makeCube());
  scene.instances.push_back({0, 0, glm::translate(glm::mat4(1.0f), glm::vec3(10, 0, 0))});
  scene.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(2, 4, 2))});
  scene.instances.push_back({7, 0, glm::mat4(1.0f)});  // names no mesh
  const Bounds b = scene.bounds();
  CHECK(b.min == glm::vec3(-1.0f, -2.0f, -1.0f));
  CHECK(b.max == glm::vec3(10.5f, 2.0f, 1.0f));
}

TEST_CASE("PCG32 matches the reference implementation's published sequence") {
  // pcg32-demo from pcg-random.org, seeded with initstate 42 and initseq 54.
  Pcg32 random(42u, 54u);
  const uint32_t expected[] = {0xa15c02b7, 0x7b47f409, 0xba1d3330,
                               0x83d2f293, 0xbfa4784b, 0xcbed606e};
  for (uint32_t value : expected) CHECK(random.next() == value);
  Pcg32 unit(7u, 1u);
  for (int i = 0; i < 10000; ++i) {
    const float u = unit.unit();
    REQUIRE(u >= 0.0f);
    REQUIRE(u < 1.0f);
  }
}

TEST_CASE("Light generator: exact count, deterministic, inside bounds and ranges") {
  LightGeneration params;
  params.count = 2000;
  params.seed = 12345;
  params.bounds = box({-3, 0.5f, -8}, {5, 2, 4});
  params.minRadius = 0.25f;
  params.maxRadius = 3.0f;
  params.minIntensity = 0.5f;
  params.maxIntensity = 10.0f;
  params.falloff = 2.5f;
  params.saturation = 0.7f;
  const std::vector<PointLight> lights = generateLights(params);
  REQUIRE(lights.size() == 2000);

  glm::vec3 mean(0.0f);
  for (const PointLight& light : lights) {
    for (int axis = 0; axis < 3; ++axis) {
      REQUIRE(light.position[axis] >= params.bounds.min[axis]);
      REQUIRE(light.position[axis] <= params.bounds.max[axis]);
    }
    REQUIRE(light.radius >= 0.25f);
    REQUIRE(light.radius <= 3.0f);
    REQUIRE(light.intensity >= 0.5f);
    REQUIRE(light.intensity <= 10.0f);
    REQUIRE(light.falloff == 2.5f);
    // HSV with value 1: the brightest channel is 1 and the dimmest 1 - saturation.
    const float high = std::max({light.color.r, light.color.g, light.color.b});
    const float low = std::min({light.color.r, light.color.g, light.color.b});
    REQUIRE(high == doctest::Approx(1.0f));
    REQUIRE(low == doctest::Approx(0.3f));
    mean += light.position / float(lights.size());
  }
  // Uniform: the mean lands near the centre (the standard error is ~0.6% of the extent here).
  const glm::vec3 offset = (mean - params.bounds.center()) / params.bounds.size();
  CHECK(std::abs(offset.x) < 0.03f);
  CHECK(std::abs(offset.y) < 0.03f);
  CHECK(std::abs(offset.z) < 0.03f);

  CHECK(sameLights(lights, generateLights(params)));
  LightGeneration other = params;
  other.seed = 12346;
  const std::vector<PointLight> different = generateLights(other);
  REQUIRE(different.size() == lights.size());
  CHECK(different[0].position != lights[0].position);
  CHECK_FALSE(sameLights(lights, different));

  // A prefix is stable: asking for more lights only appends.
  other = params;
  other.count = 10;
  CHECK(sameLights(generateLights(other), {lights.begin(), lights.begin() + 10}));

  other.count = 0;
  CHECK(generateLights(other).empty());

  // Empty bounds place everything at the origin instead of at +-FLT_MAX.
  other = params;
  other.bounds = Bounds{};
  for (const PointLight& light : generateLights(other)) CHECK(light.position == glm::vec3(0.0f));
}

TEST_CASE("Projection: Vulkan depth 0..1 and +y down in the image") {
  Camera camera;
  camera.eye = {0, 0, 5};
  camera.target = {0, 0, 0};
  camera.nearPlane = 1.0f;
  camera.farPlane = 9.0f;
  CHECK(toNdc(camera, 1.0f, {0, 0, 4}).z == doctest::Approx(0.0f).epsilon(1e-5));
  CHECK(toNdc(camera, 1.0f, {0, 0, -4}).z == doctest::Approx(1.0f).epsilon(1e-5));
  CHECK(toNdc(camera, 1.0f, {0, 1, 0}).y < 0.0f);  // world up is image up: negative y in Vulkan
  CHECK(toNdc(camera, 1.0f, {1, 0, 0}).x > 0.0f);  // right stays right

  // An eye on its target or looking straight down still yields finite matrices.
  camera.target = camera.eye;
  CHECK(finite(toNdc(camera, 1.0f, {0, 0, 0})));
  camera.target = {0, -10, 5};
  CHECK(finite(toNdc(camera, 1.0f, {0, -5, 5})));
}

TEST_CASE("frameBounds puts every corner inside the frustum, degenerate bounds included") {
  const std::vector<Bounds> cases = {
      box({-1, -1, -1}, {1, 1, 1}),
      box({-12, 0, -12}, {12, 0.1f, 12}),             // a wide floor
      box({-0.1f, 0, -0.1f}, {0.1f, 30, 0.1f}),       // a mast
      box({1000, 2000, -3000}, {1001, 2003, -2999}),  // far from the origin
      box({2, 3, 4}, {2, 3, 4}),                      // a single point
      box({-5, 0, -5}, {5, 0, 5}),                    // zero height
      box({1e-7f, 0, 0}, {2e-7f, 0, 0}),              // microscopic
  };
  for (float aspect : {16.0f / 9.0f, 1.0f, 0.5f}) {
    for (const Bounds& bounds : cases) {
      CAPTURE(aspect);
      CAPTURE(bounds.min.x);
      CAPTURE(bounds.max.y);
      const Camera camera = frameBounds(bounds, 50.0f, aspect);
      REQUIRE(finite(camera.eye));
      REQUIRE(camera.nearPlane > 0.0f);
      REQUIRE(camera.farPlane > camera.nearPlane);
      CHECK(camera.eye.y > camera.target.y);  // from above
      for (const glm::vec3& corner : corners(bounds)) CHECK(insideFrustum(camera, aspect, corner));
      CHECK(insideFrustum(camera, aspect, bounds.center()));
    }
  }
  // No bounds at all: a finite default view of the origin.
  const Camera camera = frameBounds(Bounds{});
  CHECK(finite(camera.eye));
  CHECK(insideFrustum(camera, 16.0f / 9.0f, glm::vec3(0.0f)));
}

TEST_CASE("Built-in scene: the sphere grid in view, every light requested, sane materials") {
  for (uint32_t count : {0u, 1u, 256u, 5000u}) {
    CHECK(makeBuiltinScene(count, 3).lights.size() == count);
  }
  const Scene scene = makeBuiltinScene(256, 1);
  for (const Instance& instance : scene.instances) {
    REQUIRE(instance.mesh < scene.meshes.size());
    REQUIRE(instance.material < scene.materials.size());
  }
  for (const Mesh& mesh : scene.meshes) checkMeshWellFormed(mesh);

  // The 7 x 4 grid: metallic from exactly 0 to exactly 1, roughness from glossy to fully rough.
  int sphereMaterials = 0;
  bool metallic0 = false, metallic1 = false;
  float roughnessLow = 1.0f, roughnessHigh = 0.0f;
  for (const Material& m : scene.materials) {
    REQUIRE(m.metallic >= 0.0f);
    REQUIRE(m.metallic <= 1.0f);
    REQUIRE(m.roughness >= 0.0f);
    REQUIRE(m.roughness <= 1.0f);
    if (m.name.rfind("sphere m", 0) != 0) continue;
    ++sphereMaterials;
    metallic0 = metallic0 || m.metallic == 0.0f;
    metallic1 = metallic1 || m.metallic == 1.0f;
    roughnessLow = std::min(roughnessLow, m.roughness);
    roughnessHigh = std::max(roughnessHigh, m.roughness);
  }
  CHECK(sphereMaterials == 28);
  CHECK(metallic0);
  CHECK(metallic1);
  CHECK(roughnessLow <= 0.1f);
  CHECK(roughnessHigh >= 0.9f);
  CHECK(std::any_of(scene.materials.begin(), scene.materials.end(),
                    [](const Material& m) { return m.name == "sphere m0.50 r0.30"; }));

  // The floor at y = 0 spanning about 24 m; nothing sinks below it or floats far above.
  const Bounds bounds = scene.bounds();
  CHECK(bounds.min.y == doctest::Approx(0.0f).epsilon(1e-5));
  CHECK(bounds.max.y < 5.0f);
  CHECK(bounds.size().x == doctest::Approx(24.0f));
  CHECK(bounds.size().z == doctest::Approx(24.0f));

  // Lights just above the floor, all over it.
  for (const PointLight& light : scene.lights) {
    REQUIRE(light.position.y >= 0.1f);
    REQUIRE(light.position.y <= 1.5f);
    REQUIRE(std::abs(light.position.x) <= 12.0f);
    REQUIRE(std::abs(light.position.z) <= 12.0f);
    REQUIRE(light.radius >= 1.0f);
    REQUIRE(light.radius <= 3.0f);
  }
  CHECK(sameLights(scene.lights, makeBuiltinScene(256, 1).lights));
  CHECK_FALSE(sameLights(scene.lights, makeBuiltinScene(256, 2).lights));

  // The camera looks down at the grid, and every sphere is whole in a 16:9 picture.
  const float aspect = 16.0f / 9.0f;
  const Camera& camera = scene.camera;
  CHECK(camera.eye.y > camera.target.y);
  CHECK(insideFrustum(camera, aspect, bounds.center()));
  int spheresInView = 0;
  for (const Instance& instance : scene.instances) {
    if (scene.materials[instance.material].name.rfind("sphere m", 0) != 0) continue;
    const glm::vec3 center(instance.transform[3]);
    bool whole = true;
    for (const glm::vec3& d : {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                               glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)}) {
      whole = whole && insideFrustum(camera, aspect, center + 0.45f * d, 0.02f);
    }
    spheresInView += whole;
  }
  CHECK(spheresInView == 28);
  // Far enough for the far corners of the floor.
  for (const glm::vec3& corner : corners(bounds)) {
    CHECK(glm::length(corner - camera.eye) < camera.farPlane);
  }
}

namespace {

// What the renderer relies on from any loaded scene, whatever the file looked like.
void checkLoadedScene(const Scene& scene) {
  REQUIRE_FALSE(scene.meshes.empty());
  REQUIRE_FALSE(scene.instances.empty());
  size_t emptyMeshes = 0, badIndices = 0, badVertices = 0;
  for (const Mesh& mesh : scene.meshes) {
    emptyMeshes += mesh.indices.empty() || mesh.indices.size() % 3 != 0;
    for (uint32_t i : mesh.indices) badIndices += i >= mesh.vertices.size();
    for (const Vertex& v : mesh.vertices) {
      badVertices += !finite(v.position) || std::abs(glm::length(v.normal) - 1.0f) > 1e-4f ||
                     !std::isfinite(v.uv.x + v.uv.y);
    }
  }
  CHECK(emptyMeshes == 0);
  CHECK(badIndices == 0);
  CHECK(badVertices == 0);
  for (const Instance& instance : scene.instances) {
    REQUIRE(instance.mesh < scene.meshes.size());
    REQUIRE(instance.material < scene.materials.size());
  }
  for (const Material& m : scene.materials) {
    REQUIRE(m.metallic >= 0.0f);
    REQUIRE(m.metallic <= 1.0f);
    REQUIRE(m.roughness >= 0.0f);
    REQUIRE(m.roughness <= 1.0f);
    REQUIRE(glm::all(glm::greaterThanEqual(m.baseColor, glm::vec3(0.0f))));
    REQUIRE(glm::all(glm::lessThanEqual(m.baseColor, glm::vec3(1.0f))));
  }
  const Bounds bounds = scene.bounds();
  REQUIRE_FALSE(bounds.empty());
  REQUIRE(finite(bounds.min));
  REQUIRE(finite(bounds.max));
  for (const glm::vec3& corner : corners(bounds)) {
    REQUIRE(insideFrustum(scene.camera, 16.0f / 9.0f, corner));
  }
}

std::string loadError(const fs::path& path) {
  try {
    loadModel(path);
  } catch (const ModelLoadError& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST_CASE("Loading OBJ: spider.obj") {
  const Scene scene = loadModel(kModels / "OBJ/spider.obj");
  checkLoadedScene(scene);
  CHECK(scene.meshes.size() == 19);
  CHECK(scene.instances.size() == 19);
  CHECK(scene.lights.empty());
  const glm::vec3 size = scene.bounds().size();
  CHECK(size.x > 1.0f);
  CHECK(size.y > 1.0f);
}

TEST_CASE("Loading glTF 2: material factors") {
  // No factors in the file: glTF's defaults, base colour white and roughness 1.
  const Scene box = loadModel(kModels / "glTF2/BoxTextured-glTF/BoxTextured.gltf");
  checkLoadedScene(box);
  REQUIRE(box.materials.size() == 1);
  CHECK(box.materials[0].name == "Texture");
  CHECK(box.materials[0].baseColor == glm::vec3(1.0f));
  CHECK(box.materials[0].metallic == 0.0f);
  CHECK(box.materials[0].roughness == 1.0f);
  CHECK(box.meshes[0].indices.size() == 36);

  const Scene coat = loadModel(kModels / "glTF2/ClearCoat-glTF/ClearCoatTest.gltf");
  checkLoadedScene(coat);
  auto base = std::find_if(coat.materials.begin(), coat.materials.end(),
                           [](const Material& m) { return m.name == "Simple_Base"; });
  REQUIRE(base != coat.materials.end());
  CHECK(base->baseColor.r == doctest::Approx(0.5f));
  CHECK(base->baseColor.g == doctest::Approx(0.02f));
  CHECK(base->baseColor.b == doctest::Approx(0.01f));
  CHECK(base->roughness == doctest::Approx(0.44f));
  CHECK(base->metallic == 0.0f);

  // Zero and NaN normals in the file are repaired (checkLoadedScene requires unit normals).
  checkLoadedScene(loadModel(kModels / "glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb"));
}

TEST_CASE("Loading: failures are ModelLoadErrors that name the file and the reason") {
  auto expectError = [](const fs::path& path, const std::string& reason) {
    CAPTURE(path.string());
    const std::string message = loadError(path);
    CHECK(message.find(path.filename().string()) != std::string::npos);
    CHECK(message.find(reason) != std::string::npos);
    CHECK(message.find(path.parent_path().string()) == std::string::npos);  // no server paths
  };
  expectError("/nonexistent/folder/no_such_model.obj", "does not exist");
  expectError(kModels / "OBJ", "not a regular file");
  expectError(kModels / "invalid/empty.obj", "");
  expectError(kModels / "OBJ/testpoints.obj", "contains no triangle meshes (only points or lines)");
  expectError(kModels / "OBJ/number_formats.obj", "contains no triangle meshes");  // degenerate
  expectError(kModels / "glTF2/TestNoRootNode/SceneWithoutNodes.gltf",
              "contains no triangle meshes");
  expectError(kModels / "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "non-finite");
  expectError(kModels / "glTF2/RecursiveNodes/RecursiveNodes.gltf", "recursive");
  expectError(kModels / "glTF2/MissingBin/BoxTextured.gltf", "BoxTextured0.bin");
  expectError(kModels / "glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf", "no faces");
}

// Assimp allocates whatever a header claims: invalid/OutOfMemory.off claims 353,535,235,358 faces,
// and Assimp 5.2 zero-fills ~16 GB for it (observed RSS 15.8 GB, 30 s). That is why untrusted
// files are parsed in a separate, limited process; this checks that such a process, with its
// address space capped, turns the file into a ModelLoadError rather than an abort.
TEST_CASE("Loading under a memory limit: an absurd header is a ModelLoadError") {
#if defined(__SANITIZE_ADDRESS__)
  // ASan reserves terabytes of shadow address space, so an address-space limit cannot apply.
  MESSAGE("skipped under AddressSanitizer");
#else
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    const rlimit limit{rlim_t(1) << 30, rlim_t(1) << 30};
    setrlimit(RLIMIT_AS, &limit);
    int code = 3;
    try {
      loadModel(kModels / "invalid/OutOfMemory.off");
      code = 1;
    } catch (const ModelLoadError& error) {
      code = std::string(error.what()).find("OutOfMemory.off") != std::string::npos ? 0 : 2;
    } catch (...) {
      code = 4;
    }
    _exit(code);
  }
  int status = 0;
  REQUIRE(waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
#endif
}

TEST_CASE("Loading glTF 2: KHR_lights_punctual point and spot lights") {
  // One triangle (three float3 positions, base64) and three lights on translated nodes: a point
  // light with a range, one without, and a spot light on a node turned to point its -Z down.
  const char* gltf = R"({
  "asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 5.0, "range": 4.0},
    {"type": "point", "color": [0.2, 0.4, 0.8], "intensity": 0.5},
    {"type": "spot", "color": [1, 1, 1], "intensity": 9.0, "range": 3.0,
     "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}]}},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [
    {"name": "triangle", "mesh": 0},
    {"name": "lamps", "translation": [10, 0, 0], "children": [2, 3, 4]},
    {"name": "ranged", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "unranged", "translation": [0, 1, 0], "extensions": {"KHR_lights_punctual": {"light": 1}}},
    {"name": "spot", "rotation": [-0.70710678, 0, 0, 0.70710678],
     "extensions": {"KHR_lights_punctual": {"light": 2}}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "buffers": [{"byteLength": 36, "uri":
    "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]}]
})";
  const fs::path folder = fs::temp_directory_path() / "myriad_scene_tests";
  fs::create_directories(folder);
  const fs::path file = folder / "lights.gltf";
  std::ofstream(file) << gltf;

  const Scene scene = loadModel(file);
  fs::remove(file);
  checkLoadedScene(scene);
  CHECK(scene.meshes[0].indices.size() == 3);
  REQUIRE(scene.lights.size() == 3);
  for (const PointLight& light : scene.lights) {
    CHECK(light.attenuation == Attenuation::InverseSquare);  // glTF's falloff, its candela
  }

  const PointLight& ranged = scene.lights[0];
  CHECK(ranged.type == LightType::Point);
  CHECK(ranged.position.x == doctest::Approx(11.0f));  // parent's translation applies
  CHECK(ranged.position.y == doctest::Approx(2.0f));
  CHECK(ranged.position.z == doctest::Approx(3.0f));
  CHECK(ranged.color.r == doctest::Approx(1.0f));
  CHECK(ranged.color.g == doctest::Approx(0.5f));
  CHECK(ranged.color.b == doctest::Approx(0.25f));
  CHECK(ranged.intensity == doctest::Approx(5.0f));
  CHECK(ranged.radius == doctest::Approx(4.0f));
  CHECK(ranged.falloff == doctest::Approx(16.0f));  // C = r^2: inverse-square beyond 1 m

  // No range: the cut-off where I / d^2 < 1/256 is 16 * sqrt(0.4) m, kept within 8 to 16 model
  // sizes (the spec's falloff within 1% out to twice the model's size).
  const PointLight& unranged = scene.lights[1];
  CHECK(unranged.position == glm::vec3(10.0f, 1.0f, 0.0f));
  CHECK(unranged.color.b == doctest::Approx(1.0f));
  CHECK(unranged.color.r == doctest::Approx(0.25f));
  CHECK(unranged.intensity == doctest::Approx(0.4f));
  const float modelSize = glm::length(scene.bounds().size());
  CHECK(unranged.radius ==
        doctest::Approx(std::clamp(16.0f * std::sqrt(0.4f), 8.0f * modelSize, 16.0f * modelSize)));
  const float d = 2.0f * modelSize, ratio = d / unranged.radius;
  const float window = (1.0f - ratio * ratio * ratio * ratio) * (1.0f - ratio * ratio * ratio * ratio);
  CHECK(window >= 0.99f);  // the renderer's inverse-square window (shading.glsl) at 2x the size

  // The spot: the node's -Z turned to -Y, the file's angles (radians from the axis) and range.
  const PointLight& spot = scene.lights[2];
  CHECK(spot.type == LightType::Spot);
  CHECK(spot.position == glm::vec3(10.0f, 0.0f, 0.0f));
  CHECK(spot.direction.x == doctest::Approx(0.0f));
  CHECK(spot.direction.y == doctest::Approx(-1.0f));
  CHECK(spot.direction.z == doctest::Approx(0.0f));
  CHECK(spot.innerConeAngle == doctest::Approx(0.2f));
  CHECK(spot.outerConeAngle == doctest::Approx(0.6f));
  CHECK(spot.intensity == doctest::Approx(9.0f));
  CHECK(spot.radius == doctest::Approx(3.0f));
}

namespace {

// One triangle and, on nodes, a point light, a spot light, five directional lights of different
// brightness (three are kept) and two cameras: a perspective one (aspect 1.5, no zfar) turned to
// look down, and an orthographic one.
const char* kLightsAndCamerasGltf = R"({
  "asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "point", "color": [1, 1, 1], "intensity": 20, "range": 5},
    {"type": "spot", "color": [1, 0.5, 0.5], "intensity": 40, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.4}},
    {"type": "directional", "color": [1, 1, 1], "intensity": 1.0},
    {"type": "directional", "color": [1, 1, 0.5], "intensity": 5.0},
    {"type": "directional", "color": [0.5, 0.5, 1], "intensity": 3.0},
    {"type": "directional", "color": [1, 1, 1], "intensity": 0.5},
    {"type": "directional", "color": [1, 1, 1], "intensity": 4.0}]}},
  "cameras": [
    {"type": "perspective", "perspective": {"aspectRatio": 1.5, "yfov": 0.7, "znear": 0.05}},
    {"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1, "znear": 0.1, "zfar": 50}}],
  "scene": 0,
  "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10]}],
  "nodes": [
    {"name": "triangle", "mesh": 0},
    {"name": "point", "translation": [0, 2, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "spot", "translation": [0, 3, 0], "rotation": [-0.70710678, 0, 0, 0.70710678],
     "extensions": {"KHR_lights_punctual": {"light": 1}}},
    {"name": "sun0", "extensions": {"KHR_lights_punctual": {"light": 2}}},
    {"name": "sun1", "rotation": [-0.70710678, 0, 0, 0.70710678], "extensions": {"KHR_lights_punctual": {"light": 3}}},
    {"name": "sun2", "extensions": {"KHR_lights_punctual": {"light": 4}}},
    {"name": "sun3", "extensions": {"KHR_lights_punctual": {"light": 5}}},
    {"name": "sun4", "rotation": [0, 0.70710678, 0, 0.70710678], "extensions": {"KHR_lights_punctual": {"light": 6}}},
    {"name": "overhead", "translation": [0.5, 4, 0.25], "rotation": [-0.70710678, 0, 0, 0.70710678], "camera": 0},
    {"name": "flat", "translation": [0, 0, 5], "camera": 1},
    {"name": "empty"}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "buffers": [{"byteLength": 36, "uri":
    "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]}]
})";

}  // namespace

TEST_CASE("Loading glTF 2: point, spot and directional lights all arrive; the brightest 3 directional join the sun") {
  const fs::path folder = fs::temp_directory_path() / "myriad_scene_tests";
  fs::create_directories(folder);
  const fs::path file = folder / "lights_and_cameras.gltf";
  std::ofstream(file) << kLightsAndCamerasGltf;
  const Scene scene = loadModel(file);
  fs::remove(file);
  checkLoadedScene(scene);

  REQUIRE(scene.lights.size() == 2);
  CHECK(scene.lights[0].type == LightType::Point);
  CHECK(scene.lights[0].attenuation == Attenuation::InverseSquare);
  CHECK(scene.lights[0].intensity == doctest::Approx(20.0f));
  CHECK(scene.lights[0].radius == doctest::Approx(5.0f));
  const PointLight& spot = scene.lights[1];
  CHECK(spot.type == LightType::Spot);
  CHECK(spot.attenuation == Attenuation::InverseSquare);
  CHECK(spot.intensity == doctest::Approx(40.0f));
  CHECK(spot.color.g == doctest::Approx(0.5f));
  CHECK(spot.direction.y == doctest::Approx(-1.0f));
  CHECK(spot.innerConeAngle == doctest::Approx(0.1f));
  CHECK(spot.outerConeAngle == doctest::Approx(0.4f));

  // Five directional lights: the three brightest (5, 4, 3 lux), brightest first; two dropped.
  REQUIRE(scene.extraSuns.size() == 3);
  CHECK(scene.droppedSuns == 2);
  CHECK(scene.extraSuns[0].intensity == doctest::Approx(5.0f));
  CHECK(scene.extraSuns[0].color.b == doctest::Approx(0.5f));
  CHECK(scene.extraSuns[0].direction.y == doctest::Approx(-1.0f));  // -Z turned down
  CHECK(scene.extraSuns[1].intensity == doctest::Approx(4.0f));
  CHECK(scene.extraSuns[1].direction.x == doctest::Approx(-1.0f));  // -Z turned about +Y
  CHECK(scene.extraSuns[2].intensity == doctest::Approx(3.0f));
  CHECK(scene.extraSuns[2].direction.z == doctest::Approx(-1.0f));  // the node's own -Z

  REQUIRE(scene.cameras.size() == 2);
  const ModelCamera& overhead = scene.cameras[0];
  CHECK(overhead.name == "overhead");
  CHECK(overhead.perspective);
  CHECK(overhead.yfov == doctest::Approx(0.7f).epsilon(1e-5));  // the file's yfov, recovered
  CHECK(overhead.aspectRatio == doctest::Approx(1.5f));
  CHECK(overhead.znear == doctest::Approx(0.05f));
  // No zfar in the file: Assimp 5.2.5 reads glTF's optional zfar with a default of 100, so an
  // infinite far plane cannot be told from 100.
  CHECK(overhead.zfar == doctest::Approx(100.0f));
  CHECK(overhead.position.x == doctest::Approx(0.5f));
  CHECK(overhead.position.y == doctest::Approx(4.0f));
  CHECK(overhead.position.z == doctest::Approx(0.25f));
  CHECK(overhead.direction.y == doctest::Approx(-1.0f));
  CHECK(overhead.up.z == doctest::Approx(-1.0f));  // +Y turned to -Z
  const ModelCamera& flat = scene.cameras[1];
  CHECK(flat.name == "flat");
  CHECK_FALSE(flat.perspective);
  CHECK(flat.zfar == doctest::Approx(50.0f));
  CHECK(flat.direction.z == doctest::Approx(-1.0f));
}

TEST_CASE("Loading glTF 2: Assimp's cameras test file lists its cameras") {
  const Scene scene = loadModel(kModels / "glTF2" / "cameras" / "Cameras.gltf");
  checkLoadedScene(scene);
  REQUIRE(scene.cameras.size() == 2);
  const ModelCamera& perspective = scene.cameras[0];
  CHECK(perspective.perspective);
  CHECK(perspective.yfov == doctest::Approx(0.7f).epsilon(1e-5));
  CHECK(perspective.aspectRatio == doctest::Approx(1.0f));
  CHECK(perspective.znear == doctest::Approx(0.01f));
  CHECK(perspective.zfar == doctest::Approx(100.0f));
  CHECK(perspective.position.x == doctest::Approx(0.5f));
  CHECK(perspective.position.y == doctest::Approx(0.5f));
  CHECK(perspective.position.z == doctest::Approx(3.0f));
  CHECK(perspective.direction.z == doctest::Approx(-1.0f));
  CHECK(perspective.up.y == doctest::Approx(1.0f));
  CHECK_FALSE(scene.cameras[1].perspective);
}

TEST_CASE("Loading: every OBJ and glTF test model loads or is rejected with a reason") {
  // Assimp runs in this process here, so a file that crashed it would take the suite down; none of
  // these do with Debian's Assimp 5.2.5. The service still parses untrusted files in a separate
  // process, since other formats and other files may.
  std::vector<fs::path> files;
  for (const char* folder : {"OBJ", "glTF2"}) {
    for (const auto& entry : fs::recursive_directory_iterator(kModels / folder)) {
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(),
                     [](unsigned char c) { return std::tolower(c); });
      if (entry.is_regular_file() && (ext == ".obj" || ext == ".gltf" || ext == ".glb")) {
        files.push_back(entry.path());
      }
    }
  }
  std::sort(files.begin(), files.end());
  REQUIRE(files.size() >= 60);
  int loaded = 0, rejected = 0;
  for (const fs::path& file : files) {
    CAPTURE(file.string());
    try {
      const Scene scene = loadModel(file);
      checkLoadedScene(scene);
      ++loaded;
    } catch (const ModelLoadError& error) {
      const std::string message = error.what();
      CHECK(message.find(file.filename().string()) != std::string::npos);
      CHECK(message.size() > file.filename().string().size() + 24);  // a reason, not just a name
      ++rejected;
    }
  }
  std::printf("scene_tests: %zu test models, %d loaded, %d rejected with a ModelLoadError\n",
              files.size(), loaded, rejected);
  CHECK(loaded >= 35);  // guards against a loader that rejects everything
}

TEST_CASE("environment maps: resampling to 256x128 averages larger images and repeats smaller ones") {
  using myriad::scene::kEnvironmentHeight;
  using myriad::scene::kEnvironmentWidth;
  // 512x256: each output texel is the mean of exactly its 2x2 input texels.
  std::vector<float> big(512 * 256 * 3);
  for (uint32_t y = 0; y < 256; ++y) {
    for (uint32_t x = 0; x < 512; ++x) {
      for (int c = 0; c < 3; ++c) big[(y * 512 + x) * 3 + c] = float(x % 2) + 10.0f * float(y % 2) + c;
    }
  }
  myriad::scene::EnvironmentImage a = myriad::scene::resampleEquirect(big, 512, 256);
  REQUIRE(a.rgb.size() == size_t(kEnvironmentWidth) * kEnvironmentHeight * 3);
  for (size_t i = 0; i < a.rgb.size(); i += 3) {
    CHECK(a.rgb[i] == doctest::Approx(5.5f));
    CHECK(a.rgb[i + 2] == doctest::Approx(7.5f));
  }
  // 4x2: each output texel is the input texel under its centre.
  std::vector<float> small(4 * 2 * 3);
  for (uint32_t i = 0; i < 8; ++i) small[i * 3] = small[i * 3 + 1] = small[i * 3 + 2] = float(i);
  myriad::scene::EnvironmentImage b = myriad::scene::resampleEquirect(small, 4, 2);
  for (uint32_t y : {0u, 63u, 64u, 127u}) {
    for (uint32_t x : {0u, 63u, 64u, 255u}) {
      CAPTURE(x);
      CAPTURE(y);
      CHECK(b.rgb[(y * kEnvironmentWidth + x) * 3] == float((y / 64) * 4 + x / 64));
    }
  }
  CHECK_THROWS_AS(myriad::scene::resampleEquirect(small, 5, 2), std::invalid_argument);
  CHECK_THROWS_AS(myriad::scene::resampleEquirect({}, 0, 0), std::invalid_argument);
}
