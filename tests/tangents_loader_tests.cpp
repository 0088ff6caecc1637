// MikkTSpace tangents through the loader child and the scene wire: a normal-mapped glTF primitive
// without TANGENT gets them (its mirrored seam split, the copies keeping their morph
// displacements), one without a normal map keeps w = 0.
#include <doctest/doctest.h>

#include <string>

#include "gltf_builder.h"
#include "loader/loader.h"
#include "scene/scene.h"

using namespace myriad;

namespace {

// A 1x1 PNG: the normal map's image (its content does not matter to the tangents).
constexpr const char* kPixelPng =
    "data:image/"
    "png;base64,"
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg"
    "==";

}  // namespace

TEST_CASE("tangents: the loader makes MikkTSpace tangents for a normal-mapped glTF without them") {
  test::GltfBuilder b;
  // Two quads sharing the edge x = 1, the right one's u mirrored (x = 2 back at u = 0).
  const int pos = b.positions({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0});
  const int normal = b.floats({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3", 3);
  const int uv = b.floats({0, 1, 1, 1, 1, 0, 0, 0, 0, 1, 0, 0}, "VEC2", 2);
  // A morph target moving each vertex by (0, 0, its x): the copies must move as their sources.
  const int delta = b.floats({0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 2, 0, 0, 2}, "VEC3", 3);
  const int indices =
      b.accessor(std::vector<uint16_t>{0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2}, "SCALAR", 5123, 12);
  const std::string attributes = "{\"POSITION\":" + std::to_string(pos) +
                                 ",\"NORMAL\":" + std::to_string(normal) +
                                 ",\"TEXCOORD_0\":" + std::to_string(uv) + "}";
  b.nodes.push_back("{\"children\":[1,2]}");
  b.nodes.push_back("{\"mesh\":0}");
  b.nodes.push_back("{\"mesh\":1,\"translation\":[0,2,0]}");
  b.meshes.push_back("{\"primitives\":[{\"attributes\":" + attributes +
                     ",\"indices\":" + std::to_string(indices) +
                     ",\"material\":0,\"targets\":[{\"POSITION\":" + std::to_string(delta) +
                     "}]}],\"weights\":[0]}");
  b.meshes.push_back("{\"primitives\":[{\"attributes\":" + attributes +
                     ",\"indices\":" + std::to_string(indices) + ",\"material\":1}]}");
  std::string json = b.json();
  json.pop_back();  // the closing brace
  json += std::string(
              ",\"materials\":[{\"name\":\"mapped\",\"normalTexture\":{\"index\":0}},{\"name\":"
              "\"plain\"}],") +
          "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"" + kPixelPng + "\"}]}";

  const scene::Scene s = loader::loadModelBytes(json, "mirrored.gltf");
  REQUIRE(s.meshes.size() == 2);
  const scene::Mesh* mapped = nullptr;
  const scene::Mesh* plain = nullptr;
  for (const scene::Instance& instance : s.instances) {
    (s.materials[instance.material].normalTexture.present() ? mapped : plain) =
        &s.meshes[instance.mesh];
  }
  REQUIRE(mapped != nullptr);
  REQUIRE(plain != nullptr);

  // The two seam vertices are split: one copy per side.
  REQUIRE(mapped->vertices.size() == 8);
  REQUIRE(mapped->morphTargets.size() == 1);
  REQUIRE(mapped->morphTargets[0].positions.size() == 8);
  int left = 0, right = 0;
  for (size_t v = 0; v < mapped->vertices.size(); ++v) {
    const scene::Vertex& vertex = mapped->vertices[v];
    INFO("vertex " << v << " at x " << vertex.position.x);
    CHECK(mapped->morphTargets[0].positions[v] == glm::vec3(0, 0, vertex.position.x));
    const glm::vec4 expected =
        vertex.tangent.x > 0 ? glm::vec4(1, 0, 0, 1) : glm::vec4(-1, 0, 0, -1);
    CHECK(glm::length(vertex.tangent - expected) < 1e-5f);
    (vertex.tangent.x > 0 ? left : right) += 1;
    if (vertex.position.x < 0.5f) CHECK(vertex.tangent.x > 0);
    if (vertex.position.x > 1.5f) CHECK(vertex.tangent.x < 0);
  }
  CHECK(left == 4);
  CHECK(right == 4);
  // Each triangle's corners agree on the side they are on.
  for (size_t t = 0; t < mapped->indices.size(); t += 3) {
    const float w = mapped->vertices[mapped->indices[t]].tangent.w;
    CHECK(mapped->vertices[mapped->indices[t + 1]].tangent.w == w);
    CHECK(mapped->vertices[mapped->indices[t + 2]].tangent.w == w);
  }

  // Without a normal map nothing uses tangents: the vertices stay as the file has them.
  for (const scene::Vertex& vertex : plain->vertices) CHECK(vertex.tangent == glm::vec4(0.0f));
}
