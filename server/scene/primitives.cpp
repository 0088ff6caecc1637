#include "scene/primitives.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace myriad::scene {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// 20 * 4^7 = 327,680 triangles: well past what any picture needs, and it keeps a mistaken request
// from allocating gigabytes.
constexpr uint32_t kMaxIcosphereSubdivisions = 7;

void addTriangle(Mesh& mesh, uint32_t a, uint32_t b, uint32_t c) {
  mesh.indices.insert(mesh.indices.end(), {a, b, c});
}

glm::vec2 sphericalUv(const glm::vec3& p) {
  return {0.5f - std::atan2(p.z, p.x) / (2.0f * kPi),
          std::acos(std::clamp(p.y, -1.0f, 1.0f)) / kPi};
}

}  // namespace

Mesh makeSphere(uint32_t segments, uint32_t rings) {
  segments = std::max(segments, 3u);
  rings = std::max(rings, 2u);
  Mesh mesh;
  mesh.name = "sphere";
  // One extra column duplicates the seam so u runs 0..1 without wrapping back across a triangle.
  const uint32_t columns = segments + 1;
  mesh.vertices.reserve(size_t(rings + 1) * columns);
  for (uint32_t ring = 0; ring <= rings; ++ring) {
    const float v = float(ring) / float(rings);
    const float theta = v * kPi;
    for (uint32_t segment = 0; segment <= segments; ++segment) {
      const float u = float(segment) / float(segments);
      const float phi = u * 2.0f * kPi;
      // -z for increasing phi makes u grow to the right seen from outside, so textures read
      // unmirrored, and makes (ring, ring+1, ring+1 next) counter-clockwise from outside.
      const glm::vec3 p(std::sin(theta) * std::cos(phi), std::cos(theta),
                        -std::sin(theta) * std::sin(phi));
      mesh.vertices.push_back({p, p, {u, v}});
    }
  }
  // The triangles over every `step`-th ring and segment of the vertices (1: the mesh itself).
  const auto gridTriangles = [&](uint32_t step) {
    std::vector<uint32_t> indices;
    const uint32_t gridRings = rings / step;
    const uint32_t gridSegments = segments / step;
    for (uint32_t ring = 0; ring < gridRings; ++ring) {
      for (uint32_t segment = 0; segment < gridSegments; ++segment) {
        const uint32_t a = ring * step * columns + segment * step;
        const uint32_t b = a + step * columns;
        const uint32_t c = b + step;
        const uint32_t d = a + step;
        // The quads touching a pole have two corners on it; their second triangle has no area.
        if (ring != gridRings - 1) indices.insert(indices.end(), {a, b, c});
        if (ring != 0) indices.insert(indices.end(), {a, c, d});
      }
    }
    return indices;
  };
  mesh.indices = gridTriangles(1);
  // Coarser versions over the same vertices: every 2nd, 4th, ... ring and segment, down to 8
  // segments and 4 rings (a 64x32 sphere: 32x16, 16x8 and 8x4, 4,032 -> 992 -> 240 -> 48 triangles). A
  // coarse triangle's points lie inside the sphere by at most 1 - cos of half the angle its
  // quad's diagonal spans (the diagonal's midpoint is the deepest point); the fine mesh lies
  // between it and the sphere, so that bounds the distance between the two surfaces.
  for (uint32_t step = 2; segments % step == 0 && rings % step == 0 && segments / step >= 8 &&
                          rings / step >= 4;
       step *= 2) {
    MeshLod lod;
    lod.indices = gridTriangles(step);
    const float ringAngle = kPi / float(rings / step);
    const float segmentAngle = 2.0f * kPi / float(segments / step);
    const float diagonal = std::sqrt(ringAngle * ringAngle + segmentAngle * segmentAngle);
    lod.error = 1.0f - std::cos(0.5f * std::min(diagonal, kPi));
    mesh.lods.push_back(std::move(lod));
  }
  return mesh;
}

Mesh makeIcosphere(uint32_t subdivisions) {
  subdivisions = std::min(subdivisions, kMaxIcosphereSubdivisions);
  std::vector<glm::vec3> points;
  // The icosahedron's corners are the cyclic permutations of (0, +-1, +-phi).
  const float phi = (1.0f + std::sqrt(5.0f)) * 0.5f;
  for (float s : {-1.0f, 1.0f}) {
    for (float t : {-phi, phi}) {
      points.push_back({0.0f, s, t});
      points.push_back({s, t, 0.0f});
      points.push_back({t, 0.0f, s});
    }
  }
  // Faces are the triples of mutually adjacent corners (edge length 2); deriving them rather than
  // listing them leaves no table to mistype, and each is turned to face outward below.
  std::vector<std::array<uint32_t, 3>> faces;
  auto adjacent = [&](uint32_t i, uint32_t j) {
    return std::abs(glm::length(points[i] - points[j]) - 2.0f) < 1e-3f;
  };
  const auto corners = uint32_t(points.size());
  for (uint32_t i = 0; i < corners; ++i) {
    for (uint32_t j = i + 1; j < corners; ++j) {
      for (uint32_t k = j + 1; k < corners; ++k) {
        if (adjacent(i, j) && adjacent(j, k) && adjacent(i, k)) faces.push_back({i, j, k});
      }
    }
  }
  for (auto& face : faces) {
    const glm::vec3 n =
        glm::cross(points[face[1]] - points[face[0]], points[face[2]] - points[face[0]]);
    if (glm::dot(n, points[face[0]] + points[face[1]] + points[face[2]]) < 0.0f) {
      std::swap(face[1], face[2]);
    }
  }
  for (glm::vec3& p : points) p = glm::normalize(p);

  for (uint32_t level = 0; level < subdivisions; ++level) {
    std::unordered_map<uint64_t, uint32_t> midpoints;
    auto midpoint = [&](uint32_t i, uint32_t j) {
      const uint64_t key = (uint64_t(std::min(i, j)) << 32) | std::max(i, j);
      auto [it, inserted] = midpoints.try_emplace(key, uint32_t(points.size()));
      if (inserted) points.push_back(glm::normalize(points[i] + points[j]));
      return it->second;
    };
    std::vector<std::array<uint32_t, 3>> finer;
    finer.reserve(faces.size() * 4);
    for (const auto& [a, b, c] : faces) {
      const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      finer.push_back({a, ab, ca});
      finer.push_back({b, bc, ab});
      finer.push_back({c, ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }

  Mesh mesh;
  mesh.name = "icosphere";
  mesh.vertices.reserve(points.size());
  // Shared vertices keep the mesh watertight; the price is that u wraps from 1 to 0 across one
  // column of triangles, which only shows with a texture.
  for (const glm::vec3& p : points) mesh.vertices.push_back({p, p, sphericalUv(p)});
  mesh.indices.reserve(faces.size() * 3);
  for (const auto& [a, b, c] : faces) addTriangle(mesh, a, b, c);
  return mesh;
}

Mesh makePlane(float tiles) {
  Mesh mesh;
  mesh.name = "plane";
  const glm::vec3 up(0.0f, 1.0f, 0.0f);
  mesh.vertices = {
      {{-0.5f, 0.0f, 0.5f}, up, {0.0f, tiles}},
      {{0.5f, 0.0f, 0.5f}, up, {tiles, tiles}},
      {{0.5f, 0.0f, -0.5f}, up, {tiles, 0.0f}},
      {{-0.5f, 0.0f, -0.5f}, up, {0.0f, 0.0f}},
  };
  mesh.indices = {0, 1, 2, 0, 2, 3};
  return mesh;
}

Mesh makeCube() {
  Mesh mesh;
  mesh.name = "cube";
  struct Face {
    glm::vec3 normal;
    glm::vec3 up;  // the image's up direction on this face, seen from outside
  };
  const Face faces[] = {
      {{1, 0, 0}, {0, 1, 0}},  {{-1, 0, 0}, {0, 1, 0}}, {{0, 0, 1}, {0, 1, 0}},
      {{0, 0, -1}, {0, 1, 0}}, {{0, 1, 0}, {0, 0, -1}}, {{0, -1, 0}, {0, 0, 1}},
  };
  for (const Face& face : faces) {
    // right x up = normal makes the corner order below counter-clockwise from outside.
    const glm::vec3 right = glm::cross(face.up, face.normal);
    const auto base = uint32_t(mesh.vertices.size());
    const glm::vec2 corners[] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const glm::vec2& c : corners) {
      const glm::vec3 p = 0.5f * (face.normal + c.x * right + c.y * face.up);
      mesh.vertices.push_back({p, face.normal, {0.5f * (c.x + 1.0f), 0.5f * (1.0f - c.y)}});
    }
    addTriangle(mesh, base, base + 1, base + 2);
    addTriangle(mesh, base, base + 2, base + 3);
  }
  return mesh;
}

}  // namespace myriad::scene
