#include "render/reference_bvh.h"

#include <algorithm>
#include <cmath>

namespace myriad::render::reference {

namespace {

// What the G-buffer's draws and the GPU's BVH leave out of traced shadows (see Triangle).
bool clearToTracedShadows(const scene::Material& m) {
  if (m.alphaMode == scene::AlphaMode::blend) return true;
  return m.alphaMode == scene::AlphaMode::mask && !m.baseColorTexture.present() &&
         m.alpha < m.alphaCutoff;
}

}  // namespace

std::vector<Triangle> worldTriangles(const scene::Scene& scene) {
  std::vector<Triangle> triangles;
  for (const scene::Instance& instance : scene.instances) {
    const scene::Mesh& mesh = scene.meshes.at(instance.mesh);
    const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(instance.transform)));
    const bool clear = clearToTracedShadows(scene.materials.at(instance.material));
    for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
      Triangle t;
      for (int k = 0; k < 3; ++k) {
        const scene::Vertex& v = mesh.vertices.at(mesh.indices[i + k]);
        t.p[k] = glm::vec3(instance.transform * glm::vec4(v.position, 1.0f));
        t.n[k] = normalMatrix * v.normal;
        t.uv[k] = v.uv;
      }
      t.material = instance.material;
      t.object = instance.object;
      t.semantic = instance.semantic;
      t.clearToTracedShadows = clear;
      triangles.push_back(t);
    }
  }
  return triangles;
}

bool rayMeetsTriangle(const Triangle& tri, glm::vec3 origin, glm::vec3 dir, float tMax, RayHit& hit) {
  const glm::vec3 e1 = tri.p[1] - tri.p[0];
  const glm::vec3 e2 = tri.p[2] - tri.p[0];
  const glm::vec3 pv = glm::cross(dir, e2);
  const float det = glm::dot(e1, pv);
  if (std::abs(det) < 1e-12f) return false;
  const float inv = 1.0f / det;
  const glm::vec3 tv = origin - tri.p[0];
  const float u = glm::dot(tv, pv) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  const glm::vec3 qv = glm::cross(tv, e1);
  const float v = glm::dot(dir, qv) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  const float t = glm::dot(e2, qv) * inv;
  if (t <= 0.0f || t >= tMax) return false;
  hit.t = t;
  hit.u = u;
  hit.v = v;
  return true;
}

Bvh::Bvh(std::vector<Triangle> triangles) : triangles_(std::move(triangles)) {
  const uint32_t n = uint32_t(triangles_.size());
  order_.resize(n);
  lo_.resize(n);
  hi_.resize(n);
  centroid_.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    const Triangle& t = triangles_[i];
    glm::vec3 lo = glm::min(t.p[0], glm::min(t.p[1], t.p[2]));
    glm::vec3 hi = glm::max(t.p[0], glm::max(t.p[1], t.p[2]));
    // Each box grows by more than the triangle test's rounding (relative to the coordinates'
    // size and the triangle's), so that a hit the test reports on an edge, or at a t rounded
    // past an end of the ray, is never in a box the ray misses.
    const float magnitude = std::max(glm::length(lo), glm::length(hi));
    const float pad = 1e-5f * magnitude + 1e-4f * glm::length(hi - lo) + 1e-30f;
    lo_[i] = lo - pad;
    hi_[i] = hi + pad;
    centroid_[i] = 0.5f * (lo + hi);
    order_[i] = i;
  }
  nodes_.reserve(n > 0 ? 2 * n : 1);
  nodes_.push_back({});
  if (n > 0) build(0, 0, n);
  lo_ = {};
  hi_ = {};
  centroid_ = {};
}

uint32_t Bvh::build(uint32_t node, uint32_t begin, uint32_t end) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  glm::vec3 clo = lo, chi = hi;
  for (uint32_t i = begin; i < end; ++i) {
    const uint32_t t = order_[i];
    lo = glm::min(lo, lo_[t]);
    hi = glm::max(hi, hi_[t]);
    clo = glm::min(clo, centroid_[t]);
    chi = glm::max(chi, centroid_[t]);
  }
  nodes_[node].lo = lo;
  nodes_[node].hi = hi;
  if (end - begin <= kLeafSize) {
    nodes_[node].first = begin;
    nodes_[node].count = end - begin;
    return 0;
  }
  // Half the triangles each side of the median centroid along the centroids' longest extent
  // (ties by index, so the split is one answer): not the best tree, but any split is a correct
  // one, and this one is balanced (depth log2 of the count).
  const glm::vec3 extent = chi - clo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const uint32_t middle = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end,
                   [&](uint32_t a, uint32_t b) {
                     const float ca = centroid_[a][axis], cb = centroid_[b][axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const uint32_t left = uint32_t(nodes_.size());
  nodes_.push_back({});
  nodes_.push_back({});
  nodes_[node].first = left;
  nodes_[node].count = 0;
  const uint32_t depth = 1 + std::max(build(left, begin, middle), build(left + 1, middle, end));
  depth_ = std::max(depth_, depth);
  return depth;
}

bool Bvh::meetsBox(const Node& node, glm::vec3 origin, glm::vec3 dir, float tMax) {
  float enter = 0.0f, leave = tMax;
  for (int a = 0; a < 3; ++a) {
    // Along a face's plane the slab is all or nothing (no infinities times zero).
    if (dir[a] == 0.0f) {
      if (origin[a] < node.lo[a] || origin[a] > node.hi[a]) return false;
      continue;
    }
    float t0 = (node.lo[a] - origin[a]) / dir[a];
    float t1 = (node.hi[a] - origin[a]) / dir[a];
    if (t0 > t1) std::swap(t0, t1);
    enter = std::max(enter, t0);
    leave = std::min(leave, t1);
    if (enter > leave) return false;
  }
  return true;
}

RayHit Bvh::closest(glm::vec3 origin, glm::vec3 dir) const {
  RayHit best;
  if (triangles_.empty()) return best;
  // Depth first, a child pair pushed per level: the stack holds at most depth + 1 nodes, and a
  // median-split tree over 2^32 triangles is 31 deep.
  uint32_t stack[64];
  uint32_t size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const Node& node = nodes_[stack[--size]];
    if (!meetsBox(node, origin, dir, best.t)) continue;
    if (node.count == 0) {
      stack[size++] = node.first;
      stack[size++] = node.first + 1;
      continue;
    }
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const uint32_t index = order_[i];
      RayHit hit;
      if (!rayMeetsTriangle(triangles_[index], origin, dir, std::numeric_limits<float>::max(), hit)) continue;
      // The nearest; at equal t the lowest index, which is what the loop in order keeps.
      if (hit.t < best.t || (hit.t == best.t && index < best.triangle)) {
        best = hit;
        best.triangle = index;
      }
    }
  }
  return best;
}

bool Bvh::occluded(glm::vec3 origin, glm::vec3 dir, float reach, Casters casters) const {
  if (triangles_.empty()) return false;
  uint32_t stack[64];  // as closest()
  uint32_t size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const Node& node = nodes_[stack[--size]];
    if (!meetsBox(node, origin, dir, reach)) continue;
    if (node.count == 0) {
      stack[size++] = node.first;
      stack[size++] = node.first + 1;
      continue;
    }
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const Triangle& tri = triangles_[order_[i]];
      if (casters == Casters::Traced && tri.clearToTracedShadows) continue;
      RayHit hit;
      if (rayMeetsTriangle(tri, origin, dir, reach, hit)) return true;
    }
  }
  return false;
}

RayHit closestBruteForce(std::span<const Triangle> triangles, glm::vec3 origin, glm::vec3 dir) {
  RayHit best;
  for (uint32_t i = 0; i < triangles.size(); ++i) {
    RayHit hit;
    if (rayMeetsTriangle(triangles[i], origin, dir, best.t, hit)) {
      best = hit;
      best.triangle = i;
    }
  }
  return best;
}

bool occludedBruteForce(std::span<const Triangle> triangles, glm::vec3 origin, glm::vec3 dir,
                        float reach, Casters casters) {
  for (const Triangle& tri : triangles) {
    if (casters == Casters::Traced && tri.clearToTracedShadows) continue;
    RayHit hit;
    if (rayMeetsTriangle(tri, origin, dir, reach, hit)) return true;
  }
  return false;
}

}  // namespace myriad::render::reference
