#include "scene/coverage.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace myriad::scene {

namespace {

// A convex polygon in camera space, clipped against one plane z = limit (keeping z >= limit when
// `keepAbove`, else z <= limit). A triangle clipped by two planes has at most 5 corners.
using Polygon = std::vector<glm::dvec3>;

Polygon clipZ(const Polygon& in, double limit, bool keepAbove) {
  Polygon out;
  const auto inside = [&](const glm::dvec3& p) { return keepAbove ? p.z >= limit : p.z <= limit; };
  for (size_t i = 0; i < in.size(); ++i) {
    const glm::dvec3& a = in[i];
    const glm::dvec3& b = in[(i + 1) % in.size()];
    if (inside(a)) out.push_back(a);
    if (inside(a) != inside(b)) out.push_back(a + (b - a) * ((limit - a.z) / (b.z - a.z)));
  }
  return out;
}

// Whether a pixel centre exactly on edge a->b counts (of a triangle oriented so that its area is
// positive): one of the two triangles sharing an edge walks it a->b and the other b->a, and this
// takes exactly one of the two directions, so a shared edge's pixels count once.
bool ownsEdge(glm::dvec2 a, glm::dvec2 b) {
  const glm::dvec2 d = b - a;
  return d.y > 0.0 || (d.y == 0.0 && d.x < 0.0);
}

}  // namespace

CoverageCounter::CoverageCounter(const PinholeView& view)
    : view_(view), covered_(size_t(view.width) * view.height, 0) {
  dirty_ = {int(view.width), int(view.height), 0, 0};
}

bool CoverageCounter::add(const Mesh& mesh, const glm::mat4& transform) {
  const uint64_t triangles = mesh.indices.size() / 3;
  if (triangles_ + triangles > triangleBudget) return false;
  triangles_ += triangles;
  const glm::dmat4 cameraFromModel = glm::dmat4(view_.cameraFromWorld) * glm::dmat4(transform);
  std::vector<glm::dvec3> corners(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    corners[v] = glm::dvec3(cameraFromModel * glm::dvec4(glm::dvec3(mesh.vertices[v].position), 1.0));
  }
  Polygon polygon;
  polygon.reserve(6);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
    if (i0 >= corners.size() || i1 >= corners.size() || i2 >= corners.size()) continue;
    polygon.assign({corners[i0], corners[i1], corners[i2]});
    const bool nearCut = polygon[0].z < view_.near || polygon[1].z < view_.near ||
                         polygon[2].z < view_.near;
    const bool farCut = polygon[0].z > view_.far || polygon[1].z > view_.far ||
                        polygon[2].z > view_.far;
    if (nearCut) polygon = clipZ(polygon, view_.near, true);
    if (farCut && polygon.size() >= 3) polygon = clipZ(polygon, view_.far, false);
    if (polygon.size() < 3) continue;
    std::array<glm::dvec2, 6> pixel{};
    for (size_t k = 0; k < polygon.size() && k < pixel.size(); ++k) {
      const glm::dvec3& p = polygon[k];
      pixel[k] = {view_.fx * p.x / p.z + view_.cx, view_.fy * p.y / p.z + view_.cy};
    }
    for (size_t k = 1; k + 1 < std::min(polygon.size(), pixel.size()); ++k) {
      rasterise(pixel[0], pixel[k], pixel[k + 1]);
    }
  }
  return true;
}

void CoverageCounter::rasterise(glm::vec2 a0, glm::vec2 b0, glm::vec2 c0) {
  glm::dvec2 a(a0), b(b0), c(c0);
  const auto edge = [](glm::dvec2 p, glm::dvec2 q, glm::dvec2 r) {
    return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
  };
  double area = edge(a, b, c);
  if (area == 0.0 || !std::isfinite(area)) return;
  if (area < 0.0) std::swap(b, c);  // both faces: one orientation from here on
  const int w = int(view_.width), h = int(view_.height);
  const double minX = std::min({a.x, b.x, c.x}), maxX = std::max({a.x, b.x, c.x});
  const double minY = std::min({a.y, b.y, c.y}), maxY = std::max({a.y, b.y, c.y});
  // Pixels whose centres (x + 0.5, y + 0.5) the box can hold, within the image.
  const int x0 = std::max(0, int(std::ceil(std::max(minX - 0.5, -1.0))));
  const int x1 = std::min(w - 1, int(std::floor(std::min(maxX - 0.5, double(w)))));
  const int y0 = std::max(0, int(std::ceil(std::max(minY - 0.5, -1.0))));
  const int y1 = std::min(h - 1, int(std::floor(std::min(maxY - 0.5, double(h)))));
  if (x0 > x1 || y0 > y1) return;
  const bool ownAB = ownsEdge(a, b), ownBC = ownsEdge(b, c), ownCA = ownsEdge(c, a);
  const auto inside = [](double e, bool owned) { return e > 0.0 || (e == 0.0 && owned); };
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const glm::dvec2 p{x + 0.5, y + 0.5};
      if (!inside(edge(a, b, p), ownAB) || !inside(edge(b, c, p), ownBC) ||
          !inside(edge(c, a, p), ownCA)) {
        continue;
      }
      uint8_t& cell = covered_[size_t(y) * view_.width + size_t(x)];
      if (!cell) {
        cell = 1;
        ++count_;
      }
    }
  }
  dirty_ = {std::min(dirty_.x, x0), std::min(dirty_.y, y0), std::max(dirty_.z, x1 + 1),
            std::max(dirty_.w, y1 + 1)};
}

uint64_t CoverageCounter::take() {
  for (int y = dirty_.y; y < dirty_.w; ++y) {
    std::fill_n(covered_.begin() + ptrdiff_t(size_t(y) * view_.width + size_t(dirty_.x)),
                dirty_.z - dirty_.x, uint8_t{0});
  }
  dirty_ = {int(view_.width), int(view_.height), 0, 0};
  const uint64_t count = count_;
  count_ = 0;
  return count;
}

}  // namespace myriad::scene
