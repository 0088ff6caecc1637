// MikkTSpace, written from the thesis (Mikkelsen 2008, chapter 3 and appendix) and the behaviour
// of its reference implementation, as the steps below. Where this differs from the reference it
// says so; none of the differences shows on a mesh a normal map was baked for.
//
// Everything is sorted rather than hashed: std::sort is O(n log n) whatever the values, while a
// hash of floats chosen by a hostile file can be made to collide into a quadratic table.
#include "scene/tangents.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <numeric>
#include <optional>
#include <tuple>

namespace myriad::scene {
namespace {

constexpr uint32_t kNone = UINT32_MAX;
// A corner that belongs to no group and has no group of the same vertex to borrow from.
constexpr uint32_t kFallback = UINT32_MAX - 1;

// `v` scaled to unit length, or nothing where it has none (zero, NaN, infinite). The largest
// component is divided out first, so tiny and huge vectors normalise as well as others.
std::optional<glm::vec3> unit(glm::vec3 v) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return std::nullopt;
  const float largest = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  if (!(largest > 0.0f) || !std::isfinite(largest)) return std::nullopt;
  v /= largest;
  return v / std::sqrt(glm::dot(v, v));
}

// `v` without its component along the unit normal `n`, at unit length if it has any (the
// reference normalises only vectors that are not zero, and keeps zero ones).
glm::vec3 projectedUnit(glm::vec3 v, glm::vec3 n) {
  return unit(v - n * glm::dot(n, v)).value_or(glm::vec3(0.0f));
}

// Some tangent perpendicular to `n`, for corners whose uvs say nothing (the reference leaves
// (1, 0, 0) there unprojected: it may lie along the normal).
glm::vec4 anyTangent(glm::vec3 n) {
  const std::optional<glm::vec3> normal = unit(n);
  if (!normal) return {1.0f, 0.0f, 0.0f, 1.0f};
  const glm::vec3 axis = std::abs(normal->x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return {unit(axis - *normal * glm::dot(*normal, axis)).value_or(glm::vec3(1, 0, 0)), 1.0f};
}

// A vertex as MikkTSpace identifies it: position, normal and uv compared bit for bit, -0 as +0
// (the reference compares them with ==).
using VertexKey = std::array<uint32_t, 8>;

VertexKey keyOf(const Vertex& v) {
  const float values[8] = {v.position.x, v.position.y, v.position.z, v.normal.x,
                           v.normal.y,   v.normal.z,   v.uv.x,       v.uv.y};
  VertexKey key;
  for (int i = 0; i < 8; ++i) key[i] = values[i] == 0.0f ? 0u : std::bit_cast<uint32_t>(values[i]);
  return key;
}

struct Triangle {
  std::array<uint32_t, 3> vertex{kNone, kNone, kNone};     // welded vertex of each corner
  std::array<uint32_t, 3> neighbour{kNone, kNone, kNone};  // across edge k (corner k to k+1)
  std::array<uint32_t, 3> group{kNone, kNone, kNone};      // of each corner
  glm::vec3 tangent{0.0f};                                 // unit dP/du, or zero
  bool orientPreserving = false;  // its uv winding agrees with its position winding
  // Its uvs give no tangent direction (zero uv area, or positions that do not move with u or v):
  // it joins whichever group reaches it first and adds nothing to the group's tangent.
  bool groupWithAny = true;
  bool degenerate = true;  // two corners are one vertex, or an index is out of range: no part
};

int cornerOf(const Triangle& t, uint32_t vertex) {
  for (int k = 0; k < 3; ++k) {
    if (t.vertex[k] == vertex) return k;
  }
  return -1;
}

struct Group {
  uint32_t vertex;        // the welded vertex it is a group of
  bool orientPreserving;  // its triangles' handedness
  uint32_t first = 0;     // its triangles: members[first, first + count)
  uint32_t count = 0;
};

}  // namespace

std::vector<uint32_t> generateTangents(std::vector<Vertex>& vertices,
                                       std::vector<uint32_t>& indices,
                                       const glm::mat2& uvTransform) {
  const size_t vertexCount = vertices.size();
  const size_t triangleCount = indices.size() / 3;
  // Splitting appends at most one vertex per corner; the result must stay indexable by uint32.
  if (triangleCount == 0 || vertexCount + indices.size() >= kFallback) return {};

  // 1. Weld: one representative per distinct (position, normal, uv), whatever the file's
  // indexing (Assimp's welding is by epsilon and keeps vertices that differ in other attributes).
  std::vector<uint32_t> weld(vertexCount);
  {
    std::vector<VertexKey> keys(vertexCount);
    for (size_t v = 0; v < vertexCount; ++v) keys[v] = keyOf(vertices[v]);
    std::vector<uint32_t> order(vertexCount);
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(),
              [&](uint32_t a, uint32_t b) { return std::tie(keys[a], a) < std::tie(keys[b], b); });
    for (size_t i = 0; i < order.size(); ++i) {
      weld[order[i]] =
          i > 0 && keys[order[i]] == keys[order[i - 1]] ? weld[order[i - 1]] : order[i];
    }
  }

  // 2. Each triangle's tangent direction and handedness. With e1, e2 the edges from corner 0 and
  // (s1, t1), (s2, t2) their uv differences, dP/du = (t2 e1 - t1 e2) / A and dP/dv = (s1 e2 -
  // s2 e1) / A, A = s1 t2 - s2 t1 (twice the signed uv area). Only dP/du is kept: the sign of A
  // is the handedness and the bitangent is rebuilt from it.
  std::vector<Triangle> triangles(triangleCount);
  for (size_t t = 0; t < triangleCount; ++t) {
    Triangle& tri = triangles[t];
    const uint32_t* corner = &indices[3 * t];
    if (corner[0] >= vertexCount || corner[1] >= vertexCount || corner[2] >= vertexCount) continue;
    for (int k = 0; k < 3; ++k) tri.vertex[k] = weld[corner[k]];
    if (tri.vertex[0] == tri.vertex[1] || tri.vertex[1] == tri.vertex[2] ||
        tri.vertex[2] == tri.vertex[0]) {
      continue;
    }
    tri.degenerate = false;
    const Vertex& a = vertices[corner[0]];
    const glm::vec3 e1 = vertices[corner[1]].position - a.position;
    const glm::vec3 e2 = vertices[corner[2]].position - a.position;
    const glm::vec2 st1 = uvTransform * (vertices[corner[1]].uv - a.uv);
    const glm::vec2 st2 = uvTransform * (vertices[corner[2]].uv - a.uv);
    const float area = st1.x * st2.y - st1.y * st2.x;
    tri.orientPreserving = area > 0.0f;
    const glm::vec3 alongU = st2.y * e1 - st1.y * e2;  // dP/du times A
    const glm::vec3 alongV = st1.x * e2 - st2.x * e1;  // dP/dv times A
    if (std::abs(area) > FLT_MIN) {
      const float lengthU = glm::length(alongU);
      const float lengthV = glm::length(alongV);
      const float sign = tri.orientPreserving ? 1.0f : -1.0f;
      if (lengthU > FLT_MIN) tri.tangent = alongU * (sign / lengthU);
      // The reference's test: both derivatives' magnitudes (length / |A|) are above FLT_MIN.
      tri.groupWithAny =
          !(lengthU / std::abs(area) > FLT_MIN && lengthV / std::abs(area) > FLT_MIN);
    }
  }

  // 3. Neighbours: across each edge, the triangle holding the same edge the other way round
  // (so only consistently wound ones). Where more than one does (a non-manifold edge), the n-th
  // triangle with a->b pairs with the n-th with b->a, in triangle order, as the reference's
  // first-free search does.
  {
    struct Edge {
      uint32_t from, to, triangle, k;
    };
    std::vector<Edge> edges;
    edges.reserve(triangleCount * 3);
    for (size_t t = 0; t < triangleCount; ++t) {
      const Triangle& tri = triangles[t];
      if (tri.degenerate) continue;
      for (uint32_t k = 0; k < 3; ++k) {
        edges.push_back({tri.vertex[k], tri.vertex[(k + 1) % 3], uint32_t(t), k});
      }
    }
    const auto order = [](const Edge& a, const Edge& b) {
      return std::tie(a.from, a.to, a.triangle, a.k) < std::tie(b.from, b.to, b.triangle, b.k);
    };
    std::sort(edges.begin(), edges.end(), order);
    for (size_t i = 0; i < edges.size();) {
      size_t end = i;
      while (end < edges.size() && edges[end].from == edges[i].from && edges[end].to == edges[i].to)
        ++end;
      if (edges[i].from < edges[i].to) {
        const Edge reverse{edges[i].to, edges[i].from, 0, 0};
        auto other = std::lower_bound(edges.begin(), edges.end(), reverse, order);
        for (size_t j = i; j < end && other != edges.end() && other->from == reverse.from &&
                           other->to == reverse.to;
             ++j, ++other) {
          triangles[edges[j].triangle].neighbour[edges[j].k] = other->triangle;
          triangles[other->triangle].neighbour[other->k] = edges[j].triangle;
        }
      }
      i = end;
    }
  }

  // 4. Groups: from each corner of a triangle with a tangent that no group holds yet, spread
  // around its vertex through shared edges to triangles of the same handedness. A triangle
  // without a tangent takes the handedness of the first group reaching it (the one order
  // dependency, as in the reference). Depth first, neighbour across the corner's outgoing edge
  // before the incoming one, as the reference's recursion, but on an explicit stack: a vertex
  // shared by a million triangles is a valid mesh.
  std::vector<Group> groups;
  std::vector<uint32_t> members;
  std::vector<uint32_t> stack;
  for (size_t t = 0; t < triangleCount; ++t) {
    for (int k = 0; k < 3; ++k) {
      const Triangle& start = triangles[t];
      if (start.degenerate || start.groupWithAny || start.group[k] != kNone) continue;
      Group group{start.vertex[k], start.orientPreserving, uint32_t(members.size())};
      const uint32_t id = uint32_t(groups.size());
      stack.assign(1, uint32_t(t));
      while (!stack.empty()) {
        Triangle& tri = triangles[stack.back()];
        const uint32_t index = stack.back();
        stack.pop_back();
        const int j = cornerOf(tri, group.vertex);
        if (j < 0 || tri.group[j] != kNone) continue;
        if (tri.groupWithAny && tri.group == std::array<uint32_t, 3>{kNone, kNone, kNone}) {
          tri.orientPreserving = group.orientPreserving;
        }
        if (tri.orientPreserving != group.orientPreserving) continue;
        tri.group[j] = id;
        members.push_back(index);
        if (tri.neighbour[(j + 2) % 3] != kNone) stack.push_back(tri.neighbour[(j + 2) % 3]);
        if (tri.neighbour[j] != kNone) stack.push_back(tri.neighbour[j]);
      }
      group.count = uint32_t(members.size()) - group.first;
      groups.push_back(group);
    }
  }
  // No triangle has a usable uv mapping: nothing MikkTSpace could say. The per-pixel frame
  // (w = 0) then does what can be done.
  if (groups.empty()) return {};

  // 5. Each group's tangent: its triangles' tangents projected onto the vertex normal, each
  // weighted by the triangle's angle at the vertex (measured in the tangent plane), the sum
  // normalised. The reference first splits a group into subgroups whose projected tangents lie
  // within an angular threshold of each other; at its default of 180 degrees only exactly
  // opposite tangents are apart, so a group is taken whole here (and the pairwise comparison,
  // quadratic in a vertex's triangles, is not made).
  std::vector<glm::vec4> groupTangent(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    const Group& group = groups[g];
    glm::vec3 sum(0.0f);
    glm::vec3 normal(0.0f);
    for (uint32_t m = group.first; m < group.first + group.count; ++m) {
      const Triangle& tri = triangles[members[m]];
      const int j = cornerOf(tri, group.vertex);
      if (tri.groupWithAny || j < 0) continue;
      const uint32_t* corner = &indices[3 * size_t(members[m])];
      const glm::vec3 at = vertices[corner[j]].position;
      normal = vertices[corner[j]].normal;
      const glm::vec3 toPrevious =
          projectedUnit(vertices[corner[(j + 2) % 3]].position - at, normal);
      const glm::vec3 toNext = projectedUnit(vertices[corner[(j + 1) % 3]].position - at, normal);
      const float angle = std::acos(std::clamp(glm::dot(toPrevious, toNext), -1.0f, 1.0f));
      sum += angle * projectedUnit(tri.tangent, normal);
    }
    // glTF's uv origin is the image's top left, MikkTSpace's the bottom left: the same tangent,
    // the opposite handedness (what tools writing glTF from MikkTSpace do, w *= -1).
    const float w = group.orientPreserving ? -1.0f : 1.0f;
    const std::optional<glm::vec3> tangent = unit(sum);
    groupTangent[g] =
        tangent ? glm::vec4(*tangent, w) : glm::vec4(glm::vec3(anyTangent(normal)), w);
  }

  // 6. Corners no group holds (degenerate triangles, triangles without a tangent that no group
  // reached) borrow the first group of the same vertex, else get some perpendicular tangent.
  // The reference borrows for degenerate triangles only, from the first non-degenerate corner
  // even if that one is in no group.
  std::vector<uint32_t> borrowed(vertexCount, kNone);
  for (const Triangle& tri : triangles) {
    for (int k = 0; k < 3; ++k) {
      if (tri.group[k] != kNone && borrowed[tri.vertex[k]] == kNone) {
        borrowed[tri.vertex[k]] = tri.group[k];
      }
    }
  }

  // 7. Tangents into the vertices. The first corner to reach a vertex gives it its group's
  // tangent; corners in another group get a copy of the vertex, one per (vertex, group).
  const auto tangentOf = [&](uint32_t vertex, uint32_t group) {
    return group == kFallback ? anyTangent(vertices[vertex].normal) : groupTangent[group];
  };
  struct Split {
    uint32_t vertex, group, corner;
  };
  std::vector<Split> splits;
  std::vector<uint32_t> claimedBy(vertexCount, kNone);
  for (size_t t = 0; t < triangleCount; ++t) {
    const Triangle& tri = triangles[t];
    if (tri.vertex[0] == kNone) continue;  // an index out of range: left as it is
    for (int k = 0; k < 3; ++k) {
      const uint32_t corner = uint32_t(3 * t + k);
      const uint32_t vertex = indices[corner];
      uint32_t group = tri.group[k] != kNone ? tri.group[k] : borrowed[tri.vertex[k]];
      if (group == kNone) group = kFallback;
      if (claimedBy[vertex] == kNone) {
        claimedBy[vertex] = group;
        vertices[vertex].tangent = tangentOf(vertex, group);
      } else if (claimedBy[vertex] != group) {
        splits.push_back({vertex, group, corner});
      }
    }
  }
  std::sort(splits.begin(), splits.end(), [](const Split& a, const Split& b) {
    return std::tie(a.vertex, a.group, a.corner) < std::tie(b.vertex, b.group, b.corner);
  });
  std::vector<uint32_t> copiedFrom;
  for (size_t i = 0; i < splits.size(); ++i) {
    if (i == 0 || splits[i].vertex != splits[i - 1].vertex ||
        splits[i].group != splits[i - 1].group) {
      Vertex copy = vertices[splits[i].vertex];
      copy.tangent = tangentOf(splits[i].vertex, splits[i].group);
      vertices.push_back(copy);
      copiedFrom.push_back(splits[i].vertex);
    }
    indices[splits[i].corner] = uint32_t(vertices.size() - 1);
  }
  return copiedFrom;
}

}  // namespace myriad::scene
