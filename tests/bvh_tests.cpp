// The BVH built in compute (render/bvh.h) against brute force on the CPU: thousands of random
// shadow rays through random triangle soups, the GPU's any-hit answer against the same triangle
// test (shaders/ray_triangle.glsl's C++ twin) over every triangle. Rays that pass within a
// rounding margin of some triangle's edge or end on a triangle are counted apart (either answer
// is right there); every other ray must agree. Validation layers on (fails on any message).
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "gpu_test_support.h"
#include "render/bvh.h"

using namespace myriad;
using gpu_types::BvhNode;
using gpu_types::BvhRay;
using gpu_types::BvhTriangle;

namespace {

test::GpuSuite& sharedGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

render::Bvh& sharedBvh() {
  static render::Bvh bvh(*sharedGpu().context);
  return bvh;
}

BvhTriangle triangle(glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t flags = 0) {
  float f = 0.0f;
  std::memcpy(&f, &flags, sizeof(f));
  return {glm::vec4(a, f), glm::vec4(b, 0.0f), glm::vec4(c, 0.0f)};
}

// Whether the ray passes within a rounding margin of deciding differently against `t`: its
// barycentrics near an edge, or t near an end, while it is near the triangle at all (double
// precision, the margin relative to the triangle's and the ray's size).
bool grazes(const BvhTriangle& t, const BvhRay& r) {
  const glm::dvec3 o(r.originTMin), d(r.directionTMax), a(t.v0), b(t.v1), c(t.v2);
  const double tMin = r.originTMin.w, tMax = r.directionTMax.w;
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  if (det == 0.0) return false;  // edge-on: missed by both
  const glm::dvec3 s = o - a;
  const double u = glm::dot(s, p) / det;
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(d, q) / det;
  const double tt = glm::dot(e2, q) / det;
  constexpr double kMargin = 1e-4;
  const bool inside = u > -kMargin && v > -kMargin && u + v < 1.0 + kMargin;
  // t's margin relative to the distances at hand (a long ray's tMax of 1e30 is no scale).
  const double tMargin = kMargin * (1.0 + std::abs(tt));
  const bool within = tt > tMin - tMargin && tt < tMax + tMargin;
  if (!inside || !within) return false;
  const bool nearEdge = std::abs(u) < kMargin || std::abs(v) < kMargin || std::abs(1.0 - u - v) < kMargin;
  const bool nearEnd = std::abs(tt - tMin) < tMargin || std::abs(tt - tMax) < tMargin;
  return nearEdge || nearEnd;
}

struct Agreement {
  size_t rays = 0, occluded = 0, grazing = 0, mismatches = 0;
};

Agreement compareWithBruteForce(const std::vector<BvhTriangle>& triangles,
                                const std::vector<BvhRay>& rays) {
  render::Bvh& bvh = sharedBvh();
  bvh.build(triangles);
  const std::vector<uint32_t> gpu = bvh.occluded(rays);
  REQUIRE(gpu.size() == rays.size());
  Agreement a;
  a.rays = rays.size();
  for (size_t i = 0; i < rays.size(); ++i) {
    const BvhRay& r = rays[i];
    bool hit = false, grazing = false;
    for (const BvhTriangle& t : triangles) {
      uint32_t flags = 0;
      std::memcpy(&flags, &t.v0.w, sizeof(flags));
      if (flags & MYRIAD_BVH_TRIANGLE_CLEAR) continue;
      grazing = grazing || grazes(t, r);
      hit = hit || render::rayHitsTriangle(glm::vec3(r.originTMin), glm::vec3(r.directionTMax),
                                           glm::vec3(t.v0), glm::vec3(t.v1), glm::vec3(t.v2),
                                           r.originTMin.w, r.directionTMax.w);
    }
    a.occluded += hit ? 1 : 0;
    if (grazing) {
      ++a.grazing;
      continue;
    }
    if ((gpu[i] != 0) != hit) ++a.mismatches;
  }
  MESSAGE(triangles.size() << " triangles, " << a.rays << " rays: " << a.occluded << " occluded, "
                           << a.grazing << " grazing (not judged), " << a.mismatches << " mismatches");
  CHECK(sharedGpu().context->validationMessages.load() == 0);
  return a;
}

// Segments between random points of the box [-extent, extent]^3 (the shadow rays' shape: tMin 0,
// tMax 1 along the unnormalised direction), some of them long rays with tMax large.
std::vector<BvhRay> randomRays(std::mt19937& rng, size_t count, float extent) {
  std::uniform_real_distribution<float> coord(-extent, extent);
  std::vector<BvhRay> rays(count);
  for (size_t i = 0; i < count; ++i) {
    const glm::vec3 from(coord(rng), coord(rng), coord(rng));
    const glm::vec3 to(coord(rng), coord(rng), coord(rng));
    const bool segment = i % 4 != 0;
    const glm::vec3 dir = segment ? to - from : glm::normalize(to - from);
    rays[i] = {glm::vec4(from, 0.0f), glm::vec4(dir, segment ? 1.0f : 1e30f)};
  }
  return rays;
}

// The hierarchy's shape: every node reached once from the root, n leaves holding each triangle
// once, every box holding its children's.
void checkHierarchy(size_t n) {
  const std::vector<BvhNode> nodes = sharedBvh().readNodes();
  REQUIRE(nodes.size() == 2 * n - 1);
  std::vector<int> reached(nodes.size(), 0), triangleSeen(n, 0);
  std::vector<uint32_t> stack = {0};
  size_t leaves = 0, boxErrors = 0;
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    REQUIRE(i < nodes.size());
    ++reached[i];
    uint32_t left = 0, right = 0;
    std::memcpy(&left, &nodes[i].lo.w, 4);
    std::memcpy(&right, &nodes[i].hi.w, 4);
    if (right == MYRIAD_BVH_LEAF) {
      ++leaves;
      REQUIRE(left < n);
      ++triangleSeen[left];
      continue;
    }
    for (uint32_t child : {left, right}) {
      REQUIRE(child < nodes.size());
      const glm::vec3 lo(nodes[child].lo), hi(nodes[child].hi);
      if (glm::any(glm::lessThan(lo, glm::vec3(nodes[i].lo))) ||
          glm::any(glm::greaterThan(hi, glm::vec3(nodes[i].hi)))) {
        ++boxErrors;
      }
      stack.push_back(child);
    }
  }
  CHECK(leaves == n);
  CHECK(std::count(reached.begin(), reached.end(), 1) == long(nodes.size()));
  CHECK(std::count(triangleSeen.begin(), triangleSeen.end(), 1) == long(n));
  CHECK(boxErrors == 0);
}

}  // namespace

TEST_CASE("bvh: random triangle soup, any-hit equals brute force") {
  std::mt19937 rng(34);
  std::uniform_real_distribution<float> coord(-5.0f, 5.0f);
  std::uniform_real_distribution<float> size(0.05f, 1.5f);
  std::vector<BvhTriangle> triangles;
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 a(coord(rng), coord(rng), coord(rng));
    const float s = size(rng);
    triangles.push_back(triangle(a, a + s * glm::vec3(coord(rng), coord(rng), coord(rng)) / 10.0f,
                                 a + s * glm::vec3(coord(rng), coord(rng), coord(rng)) / 10.0f));
  }
  // Duplicates (equal Morton codes: the hierarchy tells them apart by index) and a few large ones.
  for (int i = 0; i < 64; ++i) triangles.push_back(triangles[size_t(i) * 7]);
  triangles.push_back(triangle({-5, -5, 0}, {5, -5, 0}, {0, 5, 0.5f}));
  const std::vector<BvhRay> rays = randomRays(rng, 4000, 5.0f);
  const Agreement a = compareWithBruteForce(triangles, rays);
  CHECK(a.mismatches == 0);
  CHECK(a.occluded > a.rays / 10);      // the test means something: many rays are blocked
  CHECK(a.occluded < a.rays * 9 / 10);  // and many are not
  CHECK(a.grazing < a.rays / 50);
  checkHierarchy(triangles.size());
}

TEST_CASE("bvh: 20,000 triangles (many sort workgroups, a scan of several chunks)") {
  // 20,000 keys: 10 sort workgroups of 2,048, 2,560 digit counts scanned in three chunks.
  std::mt19937 rng(2026);
  std::uniform_real_distribution<float> coord(-8.0f, 8.0f);
  std::uniform_real_distribution<float> edge(-0.25f, 0.25f);
  std::vector<BvhTriangle> triangles;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 a(coord(rng), coord(rng) * 0.25f, coord(rng));  // a slab: many overlaps
    triangles.push_back(triangle(a, a + glm::vec3(edge(rng), edge(rng), edge(rng)),
                                 a + glm::vec3(edge(rng), edge(rng), edge(rng))));
  }
  const std::vector<BvhRay> rays = randomRays(rng, 2000, 8.0f);
  const Agreement a = compareWithBruteForce(triangles, rays);
  CHECK(a.mismatches == 0);
  CHECK(a.occluded > a.rays / 10);
  CHECK(a.occluded < a.rays * 9 / 10);
  checkHierarchy(triangles.size());
}

TEST_CASE("bvh: closed mesh of shared edges is watertight, cut-outs cast nothing") {
  // A grid of 40 x 40 quads (two triangles each) at y = 0 over [-4, 4]^2: every ray from above
  // to below it crosses the grid, wherever it meets the shared edges.
  std::vector<BvhTriangle> triangles;
  constexpr int kCells = 40;
  auto at = [](int i, int j) { return glm::vec3(-4.0f + 8.0f * i / kCells, 0.0f, -4.0f + 8.0f * j / kCells); };
  for (int i = 0; i < kCells; ++i) {
    for (int j = 0; j < kCells; ++j) {
      triangles.push_back(triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1)));
      triangles.push_back(triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1)));
    }
  }
  // A cut-out floating above the grid (MYRIAD_BVH_TRIANGLE_CLEAR): no ray stops at it.
  triangles.push_back(triangle({-10, 1, -10}, {10, 1, -10}, {0, 1, 10}, MYRIAD_BVH_TRIANGLE_CLEAR));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> inside(-3.9f, 3.9f);
  std::vector<BvhRay> rays;
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 from(inside(rng), 2.0f, inside(rng));
    const glm::vec3 to(inside(rng), -2.0f, inside(rng));
    rays.push_back({glm::vec4(from, 0.0f), glm::vec4(to - from, 1.0f)});
  }
  // Rays through the grid's vertices and along its edges exactly (grazing on the CPU side, but
  // the GPU must still find a hit: no ray leaks through a vertex).
  std::vector<BvhRay> throughVertices;
  for (int i = 1; i < kCells; i += 3) {
    for (int j = 1; j < kCells; j += 3) {
      const glm::vec3 v = at(i, j);
      throughVertices.push_back({glm::vec4(v + glm::vec3(0.0f, 1.0f, 0.0f), 0.0f),
                                 glm::vec4(0.0f, -2.0f, 0.0f, 1.0f)});
    }
  }
  const Agreement a = compareWithBruteForce(triangles, rays);
  CHECK(a.mismatches == 0);
  CHECK(a.occluded == a.rays);  // every ray crosses the closed grid
  const std::vector<uint32_t> vertexHits = sharedBvh().occluded(throughVertices);
  CHECK(std::count(vertexHits.begin(), vertexHits.end(), 1u) == long(throughVertices.size()));
  checkHierarchy(triangles.size());
}

TEST_CASE("bvh: one triangle, and none") {
  std::vector<BvhTriangle> one = {triangle({-1, 0, -1}, {1, 0, -1}, {0, 0, 1})};
  const std::vector<BvhRay> rays = {
      {glm::vec4(0, 1, 0, 0), glm::vec4(0, -2, 0, 1)},    // through it
      {glm::vec4(0, 1, 0, 0), glm::vec4(0, -0.5f, 0, 1)},  // ends above it
      {glm::vec4(5, 1, 0, 0), glm::vec4(0, -2, 0, 1)}};   // beside it
  render::Bvh& bvh = sharedBvh();
  bvh.build(one);
  CHECK(bvh.occluded(rays) == std::vector<uint32_t>{1, 0, 0});
  checkHierarchy(1);
  bvh.build({});
  CHECK(bvh.occluded(rays) == std::vector<uint32_t>{0, 0, 0});
  CHECK(sharedGpu().context->validationMessages.load() == 0);
}

