// The C++ reference's scene (render/reference.h) as world-space triangles, and a bounding volume
// hierarchy over them so that the reference's rays (one a pixel, and a shadow ray per light per
// pixel) need not test every triangle: the built-in scene (112,470 triangles) with 10,000 lights
// at 96x64 takes about 3 s on two cores, where brute force would test some 10^11 triangles. It
// judges the GPU's BVH (render/bvh.h), so it shares nothing with it: its own build (median
// splits over triangle centroids, on the CPU), its own triangle test (Moller-Trumbore as the
// reference always had it), its own traversal. A BVH only skips triangles a ray cannot meet; what
// a ray hits is decided by the same test as brute force, and ties are broken as brute force
// breaks them, so the answers are brute force's (the unit test checks:
// tests/reference_bvh_tests.cpp).
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace myriad::render::reference {

struct Triangle {
  glm::vec3 p[3];
  glm::vec3 n[3];
  glm::vec2 uv[3];
  uint32_t material = 0;
  uint32_t object = 0;
  uint32_t semantic = 0;
  // The GPU's BVH marks it to cast no traced shadow (shaders/bvh_triangles.comp and bvh.cpp's
  // draw table): an alpha-blended material (not in the G-buffer's draws), or an alpha-masked one
  // with no base-colour texture whose alpha factor is under its cutoff (wholly cut out).
  // Textured cut-outs cast solid shadows on the GPU, and here (the reference samples no texture).
  bool clearToTracedShadows = false;
};

// Every instance's triangles in world space, in the scene's instance and index order.
std::vector<Triangle> worldTriangles(const scene::Scene& scene);

// Where a ray meets a triangle: t along the ray and the barycentrics of p[1] (u) and p[2] (v).
struct RayHit {
  static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  uint32_t triangle = kNone;
  float t = std::numeric_limits<float>::max();
  float u = 0.0f;
  float v = 0.0f;
};

// Moller-Trumbore, either face: whether origin + t dir crosses `tri` at 0 < t < `tMax`.
bool rayMeetsTriangle(const Triangle& tri, glm::vec3 origin, glm::vec3 dir, float tMax, RayHit& hit);

// Which triangles stop a shadow ray: all of them (the shadow maps draw every instance, whatever
// its material: render/shadows.cpp) or those the GPU's BVH traces.
enum class Casters { All, Traced };

class Bvh {
 public:
  // Leaves of at most this many triangles.
  static constexpr uint32_t kLeafSize = 4;

  explicit Bvh(std::vector<Triangle> triangles);

  const std::vector<Triangle>& triangles() const { return triangles_; }

  // The first triangle along the ray (t > 0); of several at the same t, the lowest index, as a
  // loop over the triangles in order keeping the first strictly nearer one finds.
  RayHit closest(glm::vec3 origin, glm::vec3 dir) const;
  // Whether any triangle of `casters` crosses the ray at 0 < t < `reach`.
  bool occluded(glm::vec3 origin, glm::vec3 dir, float reach, Casters casters) const;

  // The nodes' count and the deepest leaf's depth (the root's is 0), for tests and messages.
  size_t nodeCount() const { return nodes_.size(); }
  uint32_t depth() const { return depth_; }

 private:
  // A box and either two children (count 0: `first` the left child, the right one follows it) or
  // `count` triangles: order_[first .. first + count).
  struct Node {
    glm::vec3 lo;
    glm::vec3 hi;
    uint32_t first = 0;
    uint32_t count = 0;
  };
  // Makes `node` the box over order_[begin, end) and its subtree; returns the subtree's depth.
  uint32_t build(uint32_t node, uint32_t begin, uint32_t end);
  // Whether the ray meets the node's box anywhere in [0, tMax] (inclusive: a triangle exactly at
  // tMax may still win a tie).
  static bool meetsBox(const Node& node, glm::vec3 origin, glm::vec3 dir, float tMax);

  std::vector<Triangle> triangles_;
  std::vector<uint32_t> order_;
  std::vector<glm::vec3> lo_, hi_, centroid_;  // per triangle, during the build
  std::vector<Node> nodes_;
  uint32_t depth_ = 0;
};

// The brute-force answers, a loop over every triangle in order: what the BVH must equal.
RayHit closestBruteForce(std::span<const Triangle> triangles, glm::vec3 origin, glm::vec3 dir);
bool occludedBruteForce(std::span<const Triangle> triangles, glm::vec3 origin, glm::vec3 dir,
                        float reach, Casters casters);

}  // namespace myriad::render::reference
