// The scene as plain CPU data: what the renderer draws and the service edits. Knows nothing of
// Vulkan or HTTP.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace myriad::scene {

struct Vertex {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  glm::vec2 uv{0.0f};
};

struct Mesh {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;  // triangle list, counter-clockwise front faces
};

// glTF 2.0 metallic-roughness factors. Base colour is linear RGB.
struct Material {
  std::string name;
  glm::vec3 baseColor{0.8f};
  float metallic = 0.0f;
  float roughness = 0.5f;
};

// One placement of a mesh in the world.
struct Instance {
  uint32_t mesh = 0;
  uint32_t material = 0;
  glm::mat4 transform{1.0f};
};

// A local light. Radiance = color * intensity * attenuation, with attenuation
// clamp((r^2 - d^2) / (C*d^2 + r^2), 0, 1): exactly zero at and beyond `radius`.
struct PointLight {
  glm::vec3 position{0.0f};
  float radius = 1.0f;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;
  float falloff = 1.0f;  // the attenuation constant C (>= 0)
};

struct Sun {
  glm::vec3 direction = glm::normalize(glm::vec3(-0.4f, -1.0f, -0.3f));  // the way light travels
  glm::vec3 color{1.0f, 0.96f, 0.9f};
  float intensity = 2.0f;
};

struct Bounds {
  glm::vec3 min{std::numeric_limits<float>::max()};
  glm::vec3 max{std::numeric_limits<float>::lowest()};

  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
  void extend(const glm::vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  glm::vec3 center() const { return 0.5f * (min + max); }
  glm::vec3 size() const { return max - min; }
};

struct Camera {
  glm::vec3 eye{0.0f, 2.0f, 6.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fovYDegrees = 50.0f;
  float nearPlane = 0.05f;
  float farPlane = 200.0f;
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Instance> instances;
  std::vector<PointLight> lights;
  Sun sun;
  glm::vec3 ambient{0.03f, 0.035f, 0.045f};
  glm::vec3 background{0.02f, 0.025f, 0.035f};
  Camera camera;  // the default view (frames the scene)

  // World-space bounds of every instance's transformed vertices.
  Bounds bounds() const;
};

}  // namespace myriad::scene
