// MikkTSpace tangents (scene/tangents.h) on meshes whose answer is known by hand: a quad, a
// mirrored-uv seam, degenerate triangles, a cylinder; and input a hostile file could give (NaN,
// indices out of range, a 300,000-triangle fan, one edge shared by many triangles) finishing with
// tangents the scene wire accepts.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "scene/tangents.h"

using namespace myriad::scene;

namespace {

Vertex vertex(glm::vec3 position, glm::vec2 uv, glm::vec3 normal = {0, 0, 1}) {
  Vertex v;
  v.position = position;
  v.normal = normal;
  v.uv = uv;
  return v;
}

// glTF's convention: uv (0, 0) at the image's top left, so +v runs down the quad.
std::vector<Vertex> quad(float x0, float u0, float u1) {
  return {vertex({x0, 0, 0}, {u0, 1}), vertex({x0 + 1, 0, 0}, {u1, 1}),
          vertex({x0 + 1, 1, 0}, {u1, 0}), vertex({x0, 1, 0}, {u0, 0})};
}

// What the scene wire (loader/scene_wire.cpp) accepts: none (all zero) or unit xyz with w = +-1.
bool wireValid(const glm::vec4& t) {
  const float length = glm::length(glm::vec3(t));
  if (t.w == 0.0f) return length == 0.0f;
  return std::abs(t.w) == 1.0f && std::abs(length - 1.0f) <= 1e-3f;
}

void checkClose(glm::vec4 actual, glm::vec4 expected) {
  INFO("tangent (" << actual.x << ", " << actual.y << ", " << actual.z << ", " << actual.w << ")");
  CHECK(glm::length(glm::vec3(actual) - glm::vec3(expected)) < 1e-5f);
  CHECK(actual.w == expected.w);
}

}  // namespace

TEST_CASE("tangents: a quad gets +u as tangent and a bitangent up the image (-v)") {
  std::vector<Vertex> vertices = quad(0, 0, 1);
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  CHECK(generateTangents(vertices, indices).empty());
  REQUIRE(vertices.size() == 4);
  for (const Vertex& v : vertices) {
    checkClose(v.tangent, {1, 0, 0, 1});
    // glTF: bitangent = w * cross(normal, tangent), towards -v (+y here).
    CHECK(glm::length(v.tangent.w * glm::cross(v.normal, glm::vec3(v.tangent)) -
                      glm::vec3(0, 1, 0)) < 1e-5f);
  }
  CHECK(indices == std::vector<uint32_t>{0, 1, 2, 0, 2, 3});
}

TEST_CASE("tangents: a normal map's texture transform turns the frame with it") {
  // KHR_texture_transform rotation pi/2 (as render/scene_upload.cpp applies it): u' = v, v' = -u.
  // The map's +u' runs down the quad (v grows downward), its -v' along +x.
  std::vector<Vertex> vertices = quad(0, 0, 1);
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  const glm::mat2 rotation(0.0f, -1.0f, 1.0f, 0.0f);  // columns: rows (0, 1) and (-1, 0)
  CHECK(generateTangents(vertices, indices, rotation).empty());
  for (const Vertex& v : vertices) {
    checkClose(v.tangent, {0, -1, 0, 1});
    CHECK(glm::length(v.tangent.w * glm::cross(v.normal, glm::vec3(v.tangent)) -
                      glm::vec3(1, 0, 0)) < 1e-5f);
  }
}

TEST_CASE("tangents: a mirrored-uv seam splits its vertices by handedness") {
  // Two quads sharing the edge x = 1; the right one's u runs back from 1 to 0 (a mirrored half,
  // as symmetric models are unwrapped). The shared vertices are one vertex (same position,
  // normal and uv) used by triangles of both handednesses.
  std::vector<Vertex> vertices = quad(0, 0, 1);
  vertices.push_back(vertex({2, 0, 0}, {0, 1}));  // 4
  vertices.push_back(vertex({2, 1, 0}, {0, 0}));  // 5
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2};
  const std::vector<uint32_t> copied = generateTangents(vertices, indices);
  // Vertices 1 and 2 keep the left side's tangent; copies carry the right side's.
  REQUIRE(copied == std::vector<uint32_t>{1, 2});
  REQUIRE(vertices.size() == 8);
  for (uint32_t v : {0u, 1u, 2u, 3u}) checkClose(vertices[v].tangent, {1, 0, 0, 1});
  for (uint32_t v : {4u, 5u, 6u, 7u}) {
    checkClose(vertices[v].tangent, {-1, 0, 0, -1});
    // Mirrored in u only: the bitangent still points up the image.
    const glm::vec3 bitangent =
        vertices[v].tangent.w * glm::cross(vertices[v].normal, glm::vec3(vertices[v].tangent));
    CHECK(glm::length(bitangent - glm::vec3(0, 1, 0)) < 1e-5f);
  }
  CHECK(vertices[6].position == vertices[1].position);
  CHECK(vertices[7].position == vertices[2].position);
  CHECK(indices == std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 6, 4, 5, 6, 5, 7});
}

TEST_CASE("tangents: degenerate triangles borrow their vertex's tangent and change nothing else") {
  std::vector<Vertex> vertices = quad(0, 0, 1);
  vertices.push_back(vertices[2]);  // 4: the same vertex as 2 under another index
  vertices.push_back(vertex({0.5f, 0.5f, 0}, {0.5f, 0.5f}));  // 5
  vertices.push_back(vertex({0.5f, 0.5f, 0}, {0.7f, 0.2f}));  // 6: zero area in positions
  vertices.push_back(vertex({3, 3, 0}, {0.3f, 0.3f}));        // 7: zero area in uv with 5
  std::vector<uint32_t> indices = {
      0, 1, 2, 0, 2, 3,  // the quad
      1, 4, 2,           // degenerate: 2 and 4 weld into one vertex
      0, 0, 1,           // degenerate: a repeated index
      5, 6, 0,           // two corners at one position (distinct uvs): a tangent from uv still
      5, 7, 5,           // degenerate
  };
  generateTangents(vertices, indices);
  for (const Vertex& v : vertices) CHECK(wireValid(v.tangent));
  // The quad's answer is untouched by its degenerate neighbours.
  for (uint32_t v : {0u, 1u, 2u, 3u}) checkClose(vertices[v].tangent, {1, 0, 0, 1});
  // The welded duplicate has the quad's tangent (borrowed through its vertex).
  checkClose(vertices[indices[7]].tangent, {1, 0, 0, 1});
  CHECK(vertices.size() >= 8);
}

TEST_CASE("tangents: a cylinder's tangents follow the circle, its uv seam kept, no split") {
  // Radius 1 around +y, u = angle / 2 pi, v = 0 at the top: the seam at angle 0 has two vertex
  // columns (u = 0 and u = 1). Every triangle's dP/du is a chord; projected onto a vertex's
  // tangent plane it is the circle's tangent there, exactly.
  constexpr int kSegments = 24;
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;
  for (int s = 0; s <= kSegments; ++s) {
    const float u = float(s) / kSegments;
    const float angle = u * 2.0f * float(M_PI);
    const glm::vec3 radial(std::cos(angle), 0, -std::sin(angle));
    vertices.push_back(vertex(radial + glm::vec3(0, 1, 0), {u, 0}, radial));
    vertices.push_back(vertex(radial, {u, 1}, radial));
  }
  for (uint32_t s = 0; s < kSegments; ++s) {
    const uint32_t top = 2 * s, bottom = 2 * s + 1, nextTop = 2 * s + 2, nextBottom = 2 * s + 3;
    // Counter-clockwise seen from outside.
    indices.insert(indices.end(), {top, bottom, nextBottom, top, nextBottom, nextTop});
  }
  const size_t before = vertices.size();
  CHECK(generateTangents(vertices, indices).empty());
  REQUIRE(vertices.size() == before);
  for (size_t v = 0; v < vertices.size(); ++v) {
    const float angle = vertices[v].uv.x * 2.0f * float(M_PI);
    INFO("vertex " << v);
    // d/d(angle) of (cos, 0, -sin); the bitangent up the cylinder (-v is +y).
    checkClose(vertices[v].tangent, {-std::sin(angle), 0, -std::cos(angle), 1});
    const glm::vec3 bitangent =
        vertices[v].tangent.w * glm::cross(vertices[v].normal, glm::vec3(vertices[v].tangent));
    CHECK(glm::length(bitangent - glm::vec3(0, 1, 0)) < 1e-5f);
  }
}

TEST_CASE("tangents: corner angles weight the triangles around a vertex") {
  // Vertex 0 (the origin, normal +z) between A = (0, 1, 2), 90 degrees there, whose uvs make its
  // tangent +x, and B = (0, 2, 3), 45 degrees there, tangent (1, 1) / sqrt 2; same handedness,
  // sharing the edge 0-2. The mean weights them 90:45.
  std::vector<Vertex> vertices = {vertex({0, 0, 0}, {0, 0}), vertex({1, 0, 0}, {1, 0}),
                                  vertex({0, 1, 0}, {0, -1}), vertex({-1, 1, 0}, {-1, -2})};
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  CHECK(generateTangents(vertices, indices).empty());
  const glm::vec3 ta(1, 0, 0);
  const glm::vec3 tb = glm::normalize(glm::vec3(1, 1, 0));
  const glm::vec3 expected = glm::normalize(float(M_PI) / 2 * ta + float(M_PI) / 4 * tb);
  checkClose(vertices[0].tangent, glm::vec4(expected, 1));
  // Not the unweighted mean: the weights matter on this vertex.
  CHECK(glm::length(glm::normalize(ta + tb) - expected) > 1e-2f);
}

TEST_CASE("tangents: no usable uvs leave the mesh untouched (the per-pixel frame stays)") {
  std::vector<Vertex> vertices = quad(0, 0, 1);
  for (Vertex& v : vertices) v.uv = {0.25f, 0.25f};
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  CHECK(generateTangents(vertices, indices).empty());
  for (const Vertex& v : vertices) CHECK(v.tangent == glm::vec4(0.0f));
}

TEST_CASE("tangents: hostile input ends quickly with tangents the wire accepts") {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  SUBCASE("NaN, infinite and huge values, indices out of range") {
    std::vector<Vertex> vertices = quad(0, 0, 1);
    vertices.push_back(vertex({nan, 0, 0}, {0.5f, 0.5f}));
    vertices.push_back(vertex({1, 1, 1}, {nan, 0}, {nan, nan, nan}));
    vertices.push_back(vertex({1, 2, 1}, {0.5f, 0.25f}, {0.5f, nan, 0}));  // a normal part NaN
    vertices.push_back(vertex({inf, 0, 0}, {1, 1}));
    vertices.push_back(vertex({3e38f, -3e38f, 0}, {3e38f, -3e38f}));
    vertices.push_back(vertex({1e-38f, 0, 0}, {1e-30f, 0}));
    std::vector<uint32_t> indices = {0, 1, 2, 0, 4, 5, 1, 6,  7, 2, 7, 8,
                                     3, 8, 0, 6, 9, 1, 0, 99, 1, 1, 2};
    generateTangents(vertices, indices);
    for (const Vertex& v : vertices) CHECK(wireValid(v.tangent));
    CHECK(indices[19] == 99);  // out of range: left for the caller's own checks
  }
  SUBCASE("a fan of 300,000 triangles around one vertex, and one edge shared by 50,000") {
    constexpr uint32_t kFan = 300000;
    std::vector<Vertex> vertices = {vertex({0, 0, 0}, {0.5f, 0.5f})};
    std::vector<uint32_t> indices;
    for (uint32_t i = 0; i <= kFan; ++i) {
      const float a = float(i) / kFan * 2.0f * float(M_PI);
      vertices.push_back(vertex({std::cos(a), std::sin(a), 0},
                                {0.5f + 0.5f * std::cos(a), 0.5f - 0.5f * std::sin(a)}));
      if (i > 0) indices.insert(indices.end(), {0, i, i + 1});
    }
    const uint32_t edgeA = uint32_t(vertices.size());
    vertices.push_back(vertex({5, 0, 0}, {0, 0}));
    vertices.push_back(vertex({6, 0, 0}, {1, 0}));
    for (uint32_t i = 0; i < 50000; ++i) {
      vertices.push_back(vertex({5.5f, 1.0f + i * 1e-3f, float(i % 2)}, {0.5f, 1.0f + i * 1e-3f}));
      // Both windings: a non-manifold edge with many candidates on each side.
      if (i % 2)
        indices.insert(indices.end(), {edgeA, edgeA + 1, uint32_t(vertices.size() - 1)});
      else
        indices.insert(indices.end(), {edgeA + 1, edgeA, uint32_t(vertices.size() - 1)});
    }
    const auto start = std::chrono::steady_clock::now();
    generateTangents(vertices, indices);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    MESSAGE("350,000 triangles in " << seconds << " s");
    CHECK(seconds < 10.0);  // a quadratic step would take hours
    for (const Vertex& v : vertices) REQUIRE(wireValid(v.tangent));
    for (uint32_t i : indices) REQUIRE(i < vertices.size());
  }
}
