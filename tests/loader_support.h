// Helpers shared by the loader, scene wire and model library tests.
#pragma once

#include <sys/wait.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <doctest/doctest.h>

#include "scene/scene.h"

namespace myriad::test {

// Assimp's test models (Debian's assimp-testmodels); MYRIAD_ASSIMP_MODELS points elsewhere, e.g.
// at a copy on a machine without the package.
inline std::filesystem::path assimpModels() {
  const char* override = std::getenv("MYRIAD_ASSIMP_MODELS");
  return override != nullptr ? override : "/usr/share/assimp/models";
}

inline std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// True when this process has no child left, running or unreaped.
inline bool noChildren() { return ::waitpid(-1, nullptr, WNOHANG) < 0 && errno == ECHILD; }

inline void requireSameScene(const scene::Scene& a, const scene::Scene& b) {
  REQUIRE(a.meshes.size() == b.meshes.size());
  REQUIRE(a.materials.size() == b.materials.size());
  REQUIRE(a.instances.size() == b.instances.size());
  REQUIRE(a.lights.size() == b.lights.size());
  for (size_t m = 0; m < a.meshes.size(); ++m) {
    REQUIRE(a.meshes[m].vertices.size() == b.meshes[m].vertices.size());
    REQUIRE(a.meshes[m].indices == b.meshes[m].indices);
    CHECK(a.meshes[m].name == b.meshes[m].name);
    CHECK(std::memcmp(a.meshes[m].vertices.data(), b.meshes[m].vertices.data(),
                      a.meshes[m].vertices.size() * sizeof(scene::Vertex)) == 0);
  }
  for (size_t i = 0; i < a.instances.size(); ++i) {
    CHECK(a.instances[i].mesh == b.instances[i].mesh);
    CHECK(a.instances[i].material == b.instances[i].material);
    CHECK(a.instances[i].transform == b.instances[i].transform);
  }
  for (size_t i = 0; i < a.materials.size(); ++i) {
    CHECK(a.materials[i].name == b.materials[i].name);
    CHECK(a.materials[i].baseColor == b.materials[i].baseColor);
    CHECK(a.materials[i].metallic == b.materials[i].metallic);
    CHECK(a.materials[i].roughness == b.materials[i].roughness);
    CHECK(a.materials[i].alpha == b.materials[i].alpha);
    CHECK(a.materials[i].emissive == b.materials[i].emissive);
    CHECK(a.materials[i].emissiveStrength == b.materials[i].emissiveStrength);
    CHECK(a.materials[i].normalScale == b.materials[i].normalScale);
    CHECK(a.materials[i].occlusionStrength == b.materials[i].occlusionStrength);
    CHECK(a.materials[i].alphaMode == b.materials[i].alphaMode);
    CHECK(a.materials[i].alphaCutoff == b.materials[i].alphaCutoff);
    CHECK(a.materials[i].doubleSided == b.materials[i].doubleSided);
    CHECK(a.materials[i].unlit == b.materials[i].unlit);
    CHECK(a.materials[i].ior == b.materials[i].ior);
    CHECK(a.materials[i].specular == b.materials[i].specular);
    CHECK(a.materials[i].clearcoat == b.materials[i].clearcoat);
    CHECK(a.materials[i].clearcoatRoughness == b.materials[i].clearcoatRoughness);
    CHECK(a.materials[i].sheenColor == b.materials[i].sheenColor);
    CHECK(a.materials[i].sheenRoughness == b.materials[i].sheenRoughness);
    // Textures by what they show, not by index or name (an image embedded in a .glb is "*N",
    // the same image beside a .gltf has its file name, and they may be found in another order).
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
      const scene::TextureRef& x = a.materials[i].texture(slot);
      const scene::TextureRef& y = b.materials[i].texture(slot);
      REQUIRE(x.present() == y.present());
      CHECK(x.sampler == y.sampler);
      CHECK(x.offset == y.offset);
      CHECK(x.scale == y.scale);
      CHECK(x.rotation == y.rotation);
      if (!x.present()) continue;
      REQUIRE(x.image < a.images.size());
      REQUIRE(y.image < b.images.size());
      CHECK(a.images[x.image].width == b.images[y.image].width);
      CHECK(a.images[x.image].height == b.images[y.image].height);
      CHECK(a.images[x.image].rgba == b.images[y.image].rgba);
    }
  }
  CHECK(a.images.size() == b.images.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    const scene::PointLight& x = a.lights[i];
    const scene::PointLight& y = b.lights[i];
    CHECK(x.position == y.position);
    CHECK(x.radius == y.radius);
    CHECK(x.color == y.color);
    CHECK(x.intensity == y.intensity);
    CHECK(x.falloff == y.falloff);
    CHECK(x.type == y.type);
    CHECK(x.attenuation == y.attenuation);
    CHECK(x.direction == y.direction);
    CHECK(x.innerConeAngle == y.innerConeAngle);
    CHECK(x.outerConeAngle == y.outerConeAngle);
  }
  REQUIRE(a.extraSuns.size() == b.extraSuns.size());
  for (size_t i = 0; i < a.extraSuns.size(); ++i) {
    CHECK(a.extraSuns[i].direction == b.extraSuns[i].direction);
    CHECK(a.extraSuns[i].color == b.extraSuns[i].color);
    CHECK(a.extraSuns[i].intensity == b.extraSuns[i].intensity);
  }
  CHECK(a.droppedSuns == b.droppedSuns);
  CHECK(a.ignoredExtensions == b.ignoredExtensions);
  REQUIRE(a.cameras.size() == b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    CHECK(a.cameras[i].name == b.cameras[i].name);
    CHECK(a.cameras[i].perspective == b.cameras[i].perspective);
    CHECK(a.cameras[i].yfov == b.cameras[i].yfov);
    CHECK(a.cameras[i].aspectRatio == b.cameras[i].aspectRatio);
    CHECK(a.cameras[i].znear == b.cameras[i].znear);
    CHECK(a.cameras[i].zfar == b.cameras[i].zfar);
    CHECK(a.cameras[i].position == b.cameras[i].position);
    CHECK(a.cameras[i].direction == b.cameras[i].direction);
    CHECK(a.cameras[i].up == b.cameras[i].up);
  }
  CHECK(a.camera.eye == b.camera.eye);
  CHECK(a.camera.target == b.camera.target);
}

}  // namespace myriad::test
