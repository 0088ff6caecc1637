// The C++ reference's BVH (render/reference_bvh.h) against a loop over every triangle: the same
// first hit (triangle, t, barycentrics) and the same any-hit answer for every ray, 0 mismatches.
// The reference judges the GPU, so its shortcut must change nothing.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "render/reference.h"
#include "render/reference_bvh.h"
#include "scene/builtin_scene.h"

using namespace myriad;
using render::reference::Bvh;
using render::reference::Casters;
using render::reference::RayHit;
using render::reference::Triangle;

namespace {

Triangle triangle(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  Triangle t;
  t.p[0] = a;
  t.p[1] = b;
  t.p[2] = c;
  return t;
}

// A soup of sizes from slivers to a tenth of the box, a few spanning all of it (like a floor
// under small objects: boxes around everything), some coplanar and some sharing edges, some
// clear to traced shadows.
std::vector<Triangle> randomSoup(uint32_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), size(0.002f, 0.2f), chance(0.0f, 1.0f);
  std::vector<Triangle> out;
  for (uint32_t i = 0; i < count; ++i) {
    const glm::vec3 centre(10.0f * unit(rng), 10.0f * unit(rng), 10.0f * unit(rng));
    const float s = chance(rng) < 0.002f ? 20.0f : size(rng) * 10.0f;
    Triangle t = triangle(centre + s * glm::vec3(unit(rng), unit(rng), unit(rng)),
                          centre + s * glm::vec3(unit(rng), unit(rng), unit(rng)),
                          centre + s * glm::vec3(unit(rng), unit(rng), unit(rng)));
    if (chance(rng) < 0.1f) {  // flat in z, as walls and floors
      for (glm::vec3& p : t.p) p.z = std::round(centre.z);
    }
    t.clearToTracedShadows = chance(rng) < 0.2f;
    out.push_back(t);
    if (chance(rng) < 0.2f) {  // a neighbour across the edge p1-p2
      out.push_back(triangle(t.p[2], t.p[1], t.p[1] + t.p[2] - t.p[0]));
    }
  }
  return out;
}

struct Ray {
  glm::vec3 origin;
  glm::vec3 dir;
  float reach;
};

// Rays from anywhere in and around the soup, half of them aimed at a triangle's vertex, edge or
// inside (so that most meet something, and many do so on an edge), some along an axis (a zero
// direction component), with reaches that end before, at and past what they aim at.
std::vector<Ray> randomRays(const std::vector<Triangle>& soup, uint32_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), chance(0.0f, 1.0f);
  std::uniform_int_distribution<size_t> pick(0, soup.size() - 1);
  std::vector<Ray> rays;
  for (uint32_t i = 0; i < count; ++i) {
    Ray r;
    r.origin = glm::vec3(14.0f * unit(rng), 14.0f * unit(rng), 14.0f * unit(rng));
    glm::vec3 to(14.0f * unit(rng), 14.0f * unit(rng), 14.0f * unit(rng));
    const float kind = chance(rng);
    if (kind < 0.5f) {
      const Triangle& t = soup[pick(rng)];
      const float a = chance(rng), b = chance(rng) * (1.0f - a);
      const float corner = chance(rng);
      if (corner < 0.2f) to = t.p[0];
      else if (corner < 0.4f) to = t.p[1] + a * (t.p[2] - t.p[1]);
      else to = t.p[0] + a * (t.p[1] - t.p[0]) + b * (t.p[2] - t.p[0]);
    } else if (kind < 0.6f) {
      to = r.origin;
      to[i % 3] += 10.0f;  // along an axis
    }
    const glm::vec3 d = to - r.origin;
    if (!(glm::length(d) > 1e-6f)) continue;
    r.dir = glm::normalize(d);
    const float length = glm::length(d);
    const float ends = chance(rng);
    r.reach = ends < 0.4f ? 0.3f * length : (ends < 0.7f ? length : 3.0f * length);
    rays.push_back(r);
  }
  return rays;
}

struct Agreement {
  size_t rays = 0, hits = 0, occluded = 0, occludedAll = 0, mismatches = 0;
};

Agreement compare(const std::vector<Triangle>& soup, const std::vector<Ray>& rays) {
  const Bvh bvh(soup);
  Agreement a;
  for (const Ray& r : rays) {
    ++a.rays;
    const RayHit fast = bvh.closest(r.origin, r.dir);
    const RayHit slow = render::reference::closestBruteForce(soup, r.origin, r.dir);
    const bool same = fast.triangle == slow.triangle && fast.t == slow.t && fast.u == slow.u &&
                      fast.v == slow.v;
    a.hits += slow.triangle != RayHit::kNone ? 1 : 0;
    a.mismatches += same ? 0 : 1;
    for (Casters casters : {Casters::All, Casters::Traced}) {
      const bool f = bvh.occluded(r.origin, r.dir, r.reach, casters);
      const bool s = render::reference::occludedBruteForce(soup, r.origin, r.dir, r.reach, casters);
      a.mismatches += f == s ? 0 : 1;
      (casters == Casters::All ? a.occludedAll : a.occluded) += s ? 1 : 0;
    }
  }
  return a;
}

}  // namespace

TEST_CASE("reference bvh: random triangle soup, first hit and any hit equal brute force") {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const std::vector<Triangle> soup = randomSoup(3000, seed);
    const std::vector<Ray> rays = randomRays(soup, 10000, seed + 100);
    const Agreement a = compare(soup, rays);
    MESSAGE("seed " << seed << ": " << soup.size() << " triangles, " << a.rays << " rays: " << a.hits
                    << " hit, " << a.occludedAll << " occluded (all casters), " << a.occluded
                    << " (traced casters), " << a.mismatches << " mismatches");
    CHECK(a.mismatches == 0);
    // The rays exercise both answers.
    CHECK(a.hits > a.rays / 4);
    CHECK(a.occluded > a.rays / 10);
    CHECK(a.occluded < a.occludedAll);
    CHECK(a.rays - a.occludedAll > a.rays / 10);
  }
}

TEST_CASE("reference bvh: the built-in scene's triangles, rays between its surfaces") {
  const std::vector<Triangle> triangles = render::reference::worldTriangles(scene::makeBuiltinScene(16, 1));
  const Bvh bvh(triangles);
  MESSAGE(triangles.size() << " triangles, " << bvh.nodeCount() << " nodes, depth " << bvh.depth());
  CHECK(bvh.depth() <= 32);
  // Rays from points on the scene's triangles to points on others: grazing spheres, ending on
  // the floor, starting on a face (as shadow rays do).
  std::mt19937 rng(7);
  std::uniform_int_distribution<size_t> pick(0, triangles.size() - 1);
  std::uniform_real_distribution<float> chance(0.0f, 1.0f);
  auto pointOn = [&](const Triangle& t) {
    const float a = chance(rng), b = chance(rng) * (1.0f - a);
    return t.p[0] + a * (t.p[1] - t.p[0]) + b * (t.p[2] - t.p[0]);
  };
  std::vector<Ray> rays;
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 from = pointOn(triangles[pick(rng)]) + glm::vec3(0.0f, 1e-3f, 0.0f);
    const glm::vec3 to = pointOn(triangles[pick(rng)]);
    if (!(glm::length(to - from) > 1e-4f)) continue;
    rays.push_back({from, glm::normalize(to - from), glm::length(to - from)});
  }
  const Agreement a = compare(triangles, rays);
  MESSAGE(a.rays << " rays: " << a.hits << " hit, " << a.occludedAll << " occluded, "
                 << a.mismatches << " mismatches");
  CHECK(a.mismatches == 0);
  CHECK(a.occludedAll > a.rays / 10);
}

TEST_CASE("reference bvh: none, one, and cut-outs cast no traced shadow") {
  const Bvh none{std::vector<Triangle>{}};
  CHECK(none.closest(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f)).triangle == RayHit::kNone);
  CHECK_FALSE(none.occluded(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 10.0f, Casters::All));
  Triangle t = triangle(glm::vec3(-1.0f, -1.0f, 2.0f), glm::vec3(1.0f, -1.0f, 2.0f), glm::vec3(0.0f, 1.0f, 2.0f));
  const Bvh one{std::vector<Triangle>{t}};
  const RayHit hit = one.closest(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f));
  CHECK(hit.triangle == 0);
  CHECK(hit.t == doctest::Approx(2.0f));
  CHECK(one.occluded(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 3.0f, Casters::Traced));
  CHECK_FALSE(one.occluded(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 1.5f, Casters::Traced));
  t.clearToTracedShadows = true;
  const Bvh clear{std::vector<Triangle>{t}};
  CHECK(clear.occluded(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 3.0f, Casters::All));
  CHECK_FALSE(clear.occluded(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 3.0f, Casters::Traced));
  CHECK(clear.closest(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f)).triangle == 0);  // still seen

  // Which materials the GPU's BVH leaves out: blended, and untextured masks under their cutoff.
  scene::Scene s;
  s.meshes.push_back({});
  s.meshes[0].vertices = {{glm::vec3(0.0f)}, {glm::vec3(1.0f, 0.0f, 0.0f)}, {glm::vec3(0.0f, 1.0f, 0.0f)}};
  s.meshes[0].indices = {0, 1, 2};
  for (int i = 0; i < 5; ++i) s.materials.push_back({});
  s.materials[1].alphaMode = scene::AlphaMode::blend;
  s.materials[2].alphaMode = scene::AlphaMode::mask;
  s.materials[2].alpha = 0.2f;  // under the cutoff 0.5: cut out
  s.materials[3].alphaMode = scene::AlphaMode::mask;
  s.materials[3].alpha = 0.7f;  // over it: solid
  s.materials[4].alphaMode = scene::AlphaMode::mask;
  s.materials[4].alpha = 0.2f;
  s.materials[4].baseColorTexture.image = 0;  // textured: solid, as on the GPU
  for (uint32_t m = 0; m < 5; ++m) s.instances.push_back({0, m, glm::mat4(1.0f)});
  const std::vector<Triangle> cut = render::reference::worldTriangles(s);
  REQUIRE(cut.size() == 5);
  CHECK_FALSE(cut[0].clearToTracedShadows);
  CHECK(cut[1].clearToTracedShadows);
  CHECK(cut[2].clearToTracedShadows);
  CHECK_FALSE(cut[3].clearToTracedShadows);
  CHECK_FALSE(cut[4].clearToTracedShadows);
}

TEST_CASE("reference bvh: the built-in scene with 10,000 shadowed lights at 96x64 in seconds") {
  const scene::Scene s = scene::makeBuiltinScene(10000, 1);
  render::FrameSettings f;
  f.width = 96;
  f.height = 64;
  f.camera = s.camera;
  f.technique = render::Technique::Clustered;
  f.shadows.local = render::LocalShadows::Stochastic;  // every light's exact shadow
  f.takeLightingFrom(s);
  const auto start = std::chrono::steady_clock::now();
  std::vector<glm::vec3> radiance;
  const std::vector<uint8_t> image = render::renderReference(s, f, nullptr, &radiance);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE("reference: " << seconds << " s");
  CHECK(image.size() == size_t(96) * 64 * 4);
  // A brute-force reference took minutes here; a regression to it fails (generously: the test
  // machines' cores are shared).
  CHECK(seconds < 60.0);
}
