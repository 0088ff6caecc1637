// The sun's cascaded shadow maps (render/shadows.h) on a 200 m field, through the real frame's
// `shadow` view (validation on, every raw value finite):
//  - the shadows of a box 5 m from the camera and of a wall 100 m away lie within 2 px of their
//    analytic outlines (each box's corners pushed along the sun onto the ground, projected with
//    the camera), where one map over the whole field (cascades 1) is printed for contrast;
//  - a static shadow edge seen from a camera translating and turning slowly over 30 frames stays
//    put in the world to well under half a shadow texel frame to frame (the maps move by whole
//    texels), printed against the same run with the snap off.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "render/renderer.h"
#include "render/shadows.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

test::GpuSuite& cascadeGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 320;
constexpr uint32_t kHeight = 180;
const glm::vec3 kSunTravel = glm::normalize(glm::vec3(0.9f, -1.0f, -0.2f));
const glm::vec3 kEye(0.0f, 2.0f, 0.0f);

struct Box {
  glm::vec3 min, max;
};
// The field: 40 m across (x), 200 m along the view (z from 5 to -195), at y = 0.
constexpr float kFieldHalfWidth = 20.0f;
constexpr float kFieldNear = 5.0f, kFieldFar = -195.0f;
// A box about 5 m ahead, a wall about 100 m ahead (30 m along the view, so its shadow spans rows
// even at that grazing angle), and thin posts between.
const std::array<Box, 5> kBoxes = {
    Box{{-2.0f, 0.0f, -7.0f}, {-1.5f, 1.0f, -3.0f}},    // 0: ~5 m (3 to 7 m along the view)
    Box{{2.0f, 0.0f, -115.0f}, {3.0f, 4.0f, -85.0f}},   // 1: ~100 m
    Box{{-3.1f, 0.0f, -20.1f}, {-2.9f, 3.0f, -19.9f}},  // posts
    Box{{-4.1f, 0.0f, -50.1f}, {-3.9f, 3.0f, -49.9f}},
    Box{{6.0f, 0.0f, -150.5f}, {7.0f, 5.0f, -149.5f}}};

scene::Scene field() {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(1.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"ground", glm::vec3(0.6f), 0.0f, 0.9f});
  s.materials.push_back({"box", glm::vec3(0.3f, 0.5f, 0.8f), 0.0f, 0.5f});
  s.instances.push_back(
      {0, 0,
       glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 0.5f * (kFieldNear + kFieldFar))),
                  glm::vec3(2.0f * kFieldHalfWidth, 1.0f, kFieldNear - kFieldFar))});
  for (const Box& b : kBoxes) {
    s.instances.push_back({1, 1, glm::scale(glm::translate(glm::mat4(1.0f), 0.5f * (b.min + b.max)),
                                            b.max - b.min)});
  }
  s.sun.direction = kSunTravel;
  s.sun.intensity = 3.0f;
  s.ambient = glm::vec3(0.05f);
  return s;
}

scene::Camera lookingAt(glm::vec3 eye, glm::vec3 target, float fov) {
  scene::Camera c;
  c.eye = eye;
  c.target = target;
  c.fovYDegrees = fov;
  c.nearPlane = 0.1f;
  c.farPlane = 300.0f;
  return c;
}

render::FrameSettings shadowView(const scene::Camera& camera, uint32_t cascades, uint32_t mapSize) {
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera = camera;
  f.markers = false;
  f.antialias = render::Antialias::None;
  f.technique = render::Technique::Clustered;
  f.target = render::Target::Shadow;
  f.raw = true;
  f.shadows.sun = true;
  f.shadows.mapSize = mapSize;
  f.shadows.cascades = cascades;
  return f;
}

// The camera's pixel rays and projection.
struct View {
  glm::mat4 viewProjection, inverse;
  explicit View(const scene::Camera& c) {
    viewProjection = scene::projectionMatrix(c, float(kWidth) / float(kHeight)) * scene::viewMatrix(c);
    inverse = glm::inverse(viewProjection);
  }
  // The ray through image point (u, v) (pixels, top-left corner of the image at 0, 0).
  void ray(float u, float v, glm::vec3& origin, glm::vec3& direction) const {
    const glm::vec2 ndc(u / float(kWidth) * 2.0f - 1.0f, v / float(kHeight) * 2.0f - 1.0f);
    const glm::vec4 a = inverse * glm::vec4(ndc, 0.0f, 1.0f);
    const glm::vec4 b = inverse * glm::vec4(ndc, 1.0f, 1.0f);
    origin = glm::vec3(a) / a.w;
    direction = glm::normalize(glm::vec3(b) / b.w - origin);
  }
  // Where the ray through (u, v) meets the ground plane y = 0.
  std::optional<glm::vec3> ground(float u, float v) const {
    glm::vec3 o, d;
    ray(u, v, o, d);
    if (d.y >= -1e-6f) return std::nullopt;
    return o + d * (-o.y / d.y);
  }
  std::optional<glm::vec2> project(glm::vec3 p) const {
    const glm::vec4 clip = viewProjection * glm::vec4(p, 1.0f);
    if (clip.w <= 1e-4f) return std::nullopt;
    return glm::vec2((clip.x / clip.w * 0.5f + 0.5f) * float(kWidth),
                     (clip.y / clip.w * 0.5f + 0.5f) * float(kHeight));
  }
};

std::optional<float> hitBox(const Box& b, glm::vec3 o, glm::vec3 d) {
  float t0 = 0.0f, t1 = 1e30f;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12f) {
      if (o[a] < b.min[a] || o[a] > b.max[a]) return std::nullopt;
      continue;
    }
    float ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return std::nullopt;
  return t0;
}

float cross2(glm::vec2 o, glm::vec2 a, glm::vec2 b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// A box's shadow on the ground: the convex hull (x, z; counter-clockwise) of its footprint and its
// top corners pushed along the sun onto y = 0.
std::vector<glm::vec2> shadowPolygon(const Box& b) {
  std::vector<glm::vec2> points;
  const float t = b.max.y / -kSunTravel.y;
  for (float x : {b.min.x, b.max.x}) {
    for (float z : {b.min.z, b.max.z}) {
      points.push_back({x, z});
      points.push_back({x + kSunTravel.x * t, z + kSunTravel.z * t});
    }
  }
  std::sort(points.begin(), points.end(),
            [](glm::vec2 a, glm::vec2 c) { return a.x < c.x || (a.x == c.x && a.y < c.y); });
  std::vector<glm::vec2> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {  // Andrew's monotone chain
    while (k >= 2 && cross2(hull[k - 2], hull[k - 1], points[i]) <= 0.0f) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross2(hull[k - 2], hull[k - 1], points[i]) <= 0.0f) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

bool inside(const std::vector<glm::vec2>& polygon, glm::vec2 p) {
  for (size_t i = 0; i < polygon.size(); ++i) {
    if (cross2(polygon[i], polygon[(i + 1) % polygon.size()], p) < 0.0f) return false;
  }
  return true;
}

float segmentDistance(glm::vec2 p, glm::vec2 a, glm::vec2 b) {
  const glm::vec2 ab = b - a;
  const float t = std::clamp(glm::dot(p - a, ab) / std::max(glm::dot(ab, ab), 1e-12f), 0.0f, 1.0f);
  return glm::length(p - (a + t * ab));
}

// The projected outline of a ground polygon: its edges cut into short pieces, each projected
// (pieces behind the camera are left out; a polygon crossing the view plane keeps the rest).
std::vector<std::array<glm::vec2, 2>> projectedOutline(const View& view,
                                                       const std::vector<glm::vec2>& polygon) {
  std::vector<std::array<glm::vec2, 2>> pieces;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const glm::vec2 a = polygon[i], b = polygon[(i + 1) % polygon.size()];
    constexpr int kPieces = 64;
    for (int j = 0; j < kPieces; ++j) {
      const glm::vec2 p = glm::mix(a, b, float(j) / kPieces), q = glm::mix(a, b, float(j + 1) / kPieces);
      const auto pp = view.project({p.x, 0.0f, p.y}), pq = view.project({q.x, 0.0f, q.y});
      if (pp && pq) pieces.push_back({*pp, *pq});
    }
  }
  return pieces;
}

struct OutlineError {
  size_t groundPixels = 0, shadowedPixels = 0, mismatched = 0;
  float worst = 0.0f;  // px from the box's outline, of the mismatched pixels nearest to it
  size_t cascade = 0;  // the cascade the box's shadowed pixels read (the most of them)
};

// Every ground pixel (not behind a box, on the field) of a raw shadow view against the analytic
// shadows: lit below 0.5 where the pixel centre's ground point is inside a box's shadow polygon.
// A pixel that disagrees is charged to the box whose projected outline is nearest.
OutlineError outlineError(const render::Frame& frame, const scene::Camera& camera, size_t box) {
  const View view(camera);
  std::vector<std::vector<glm::vec2>> polygons;
  std::vector<std::vector<std::array<glm::vec2, 2>>> outlines;
  for (const Box& b : kBoxes) {
    polygons.push_back(shadowPolygon(b));
    outlines.push_back(projectedOutline(view, polygons.back()));
  }
  OutlineError e;
  std::array<size_t, 5> cascades{};
  for (uint32_t y = 0; y < kHeight; ++y) {
    for (uint32_t x = 0; x < kWidth; ++x) {
      glm::vec3 o, d;
      view.ray(float(x) + 0.5f, float(y) + 0.5f, o, d);
      if (d.y >= -1e-6f) continue;
      const float tGround = -o.y / d.y;
      const glm::vec3 g = o + d * tGround;
      if (std::abs(g.x) > kFieldHalfWidth || g.z > kFieldNear || g.z < kFieldFar) continue;
      bool hidden = false;
      for (const Box& b : kBoxes) {
        const std::optional<float> t = hitBox(b, o, d);
        hidden = hidden || (t && *t < tGround);
      }
      if (hidden) continue;
      ++e.groundPixels;
      bool analytic = false;
      for (const auto& polygon : polygons) analytic = analytic || inside(polygon, {g.x, g.z});
      const size_t i = (size_t(y) * kWidth + x) * 4;
      const bool dark = frame.data[i] < 0.5f;
      e.shadowedPixels += dark ? 1 : 0;
      if (analytic && inside(polygons[box], {g.x, g.z})) {
        const int c = int(frame.data[i + 1]);
        if (c >= 0 && c < 4) ++cascades[size_t(c)];
      }
      if (dark == analytic) continue;
      const glm::vec2 p(float(x) + 0.5f, float(y) + 0.5f);
      float nearest = 1e30f, nearestOther = 1e30f;
      for (size_t b = 0; b < kBoxes.size(); ++b) {
        for (const auto& piece : outlines[b]) {
          const float dist = segmentDistance(p, piece[0], piece[1]);
          if (b == box) nearest = std::min(nearest, dist);
          else nearestOther = std::min(nearestOther, dist);
        }
      }
      if (nearest <= nearestOther) {
        ++e.mismatched;
        e.worst = std::max(e.worst, nearest);
      }
    }
  }
  e.cascade = size_t(std::max_element(cascades.begin(), cascades.end()) - cascades.begin());
  return e;
}

size_t nonFinite(const render::Frame& frame) {
  size_t n = 0;
  for (float v : frame.data) n += std::isfinite(v) ? 0 : 1;
  return n;
}

}  // namespace

TEST_CASE("sun cascades: shadow edges 5 m and 100 m away lie within 2 px of the analytic outline") {
  test::GpuSuite& gpu = cascadeGpu();
  gpu.setScene(field());
  // Near: looking down the field at the box's shadow. Far: a narrow view 100 m down it, so the
  // wall's shadow spans a few rows.
  const scene::Camera nearCamera = lookingAt(kEye, glm::vec3(-0.8f, 0.0f, -5.0f), 60.0f);
  const scene::Camera farCamera = lookingAt(kEye, glm::vec3(4.0f, 0.0f, -100.0f), 10.0f);
  constexpr uint32_t kMap = 2048;
  struct Case {
    const char* name;
    const scene::Camera* camera;
    size_t box;
  };
  for (const Case& c : {Case{"5 m", &nearCamera, 0}, Case{"100 m", &farCamera, 1}}) {
    CAPTURE(std::string(c.name));
    const render::Frame cascaded = gpu.render(shadowView(*c.camera, 4, kMap));
    const render::Frame single = gpu.render(shadowView(*c.camera, 1, kMap));
    CHECK(nonFinite(cascaded) == 0);
    CHECK(nonFinite(single) == 0);
    const OutlineError withCascades = outlineError(cascaded, *c.camera, c.box);
    const OutlineError withOne = outlineError(single, *c.camera, c.box);
    MESSAGE("box " << std::string(c.name) << " away: " << withCascades.groundPixels << " ground pixels, "
                   << withCascades.shadowedPixels << " shadowed; 4 cascades (its shadow in cascade "
                   << withCascades.cascade << "): " << withCascades.mismatched
                   << " pixels off, the worst " << withCascades.worst
                   << " px from the outline; one map: " << withOne.mismatched
                   << " off, the worst " << withOne.worst << " px");
    REQUIRE(withCascades.shadowedPixels > 100);
    CHECK(withCascades.worst <= 2.0f);
    // Near the camera the cascade's texels are far smaller than the one map's.
    if (c.box == 0) {
      CHECK(withCascades.cascade == 0);
      CHECK(withOne.worst > withCascades.worst);
    } else {
      CHECK(withCascades.cascade == 3);
    }
  }

  // The 8-bit view: the factor tinted by cascade, red near, yellow (the last) far.
  render::FrameSettings picture = shadowView(farCamera, 4, kMap);
  picture.raw = false;
  const render::Frame far = gpu.render(picture);
  picture.camera = nearCamera;
  const render::Frame near = gpu.render(picture);
  // A lit ground pixel below the wall's shadow, and one near the camera.
  const auto pixel = [](const render::Frame& f, glm::vec2 p) {
    const size_t i = (size_t(p.y) * kWidth + size_t(p.x)) * 4;
    return glm::ivec3(f.rgba[i], f.rgba[i + 1], f.rgba[i + 2]);
  };
  const std::optional<glm::vec2> farLit = View(farCamera).project({-2.0f, 0.0f, -100.0f});
  const std::optional<glm::vec2> nearLit = View(nearCamera).project({0.5f, 0.0f, -4.0f});
  REQUIRE(farLit);
  REQUIRE(nearLit);
  CHECK(pixel(far, *farLit) == glm::ivec3(255, 255, 0));
  CHECK(pixel(near, *nearLit) == glm::ivec3(255, 0, 0));
  // Inside the near box's shadow: black.
  const std::optional<glm::vec2> nearDark = View(nearCamera).project({-0.9f, 0.0f, -3.6f});
  REQUIRE(nearDark);
  CHECK(pixel(near, *nearDark) == glm::ivec3(0, 0, 0));
  CHECK(gpu.context->validationMessages.load() == 0);
}

namespace {

// The world x of the near box's far shadow edge (x = max.x + height * sun.x / -sun.y, a line along
// z) seen from `camera`, at fixed points of the world: along 40 ground lines z = const across the
// edge, the lit value sampled every 2 mm (bilinear between pixel centres) and where it crosses
// 0.5 (shadow on the -x side); the mean over the lines. Fixed world lines, so a camera that moves
// samples the same edge points.
std::optional<double> edgeX(const render::Frame& frame, const scene::Camera& camera, size_t& lines) {
  const View view(camera);
  const Box& b = kBoxes[0];
  const float t = b.max.y / -kSunTravel.y;
  const float edge = b.max.x + kSunTravel.x * t;
  const float z0 = b.min.z + kSunTravel.z * t + 0.3f, z1 = b.max.z + kSunTravel.z * t - 0.3f;
  const auto litAt = [&](glm::vec3 p) -> std::optional<float> {
    const std::optional<glm::vec2> uv = view.project(p);
    if (!uv) return std::nullopt;
    const glm::vec2 q = *uv - 0.5f;  // pixel centres at whole numbers
    const int x = int(std::floor(q.x)), y = int(std::floor(q.y));
    if (x < 0 || y < 0 || x + 1 >= int(kWidth) || y + 1 >= int(kHeight)) return std::nullopt;
    const glm::vec2 f = q - glm::vec2(x, y);
    const auto at = [&](int i, int j) { return frame.data[(size_t(j) * kWidth + size_t(i)) * 4]; };
    return glm::mix(glm::mix(at(x, y), at(x + 1, y), f.x), glm::mix(at(x, y + 1), at(x + 1, y + 1), f.x), f.y);
  };
  double sum = 0.0;
  lines = 0;
  constexpr int kLines = 40;
  for (int j = 0; j < kLines; ++j) {
    const float z = glm::mix(z0, z1, (float(j) + 0.5f) / kLines);
    std::optional<float> previous;
    for (float x = edge - 0.4f; x <= edge + 0.4f; x += 0.002f) {
      const std::optional<float> lit = litAt({x, 0.0f, z});
      if (!lit) break;
      if (previous && *previous < 0.5f && *lit >= 0.5f) {
        sum += x - 0.002f * (*lit - 0.5f) / (*lit - *previous);
        ++lines;
        break;
      }
      previous = lit;
    }
  }
  if (lines == 0) return std::nullopt;
  return sum / double(lines);
}

}  // namespace

TEST_CASE("sun cascades: a static shadow edge does not shimmer while the camera moves") {
  test::GpuSuite& gpu = cascadeGpu();
  gpu.setScene(field());
  // 256-texel maps: the near cascade's texels are large (about 6 cm, three pixels at the edge),
  // so a map that slid by parts of a texel would show.
  constexpr uint32_t kMap = 256;
  constexpr int kFrames = 30;
  // A narrow view from above and to the right of the box's shadow, so that a pixel is a third of a
  // texel there and the edge is sampled finely: 1.5 cm along and 1 cm across a frame, turning by
  // 0.05 degrees a frame.
  const auto cameraAt = [](int i) {
    const glm::vec3 eye = glm::vec3(1.5f, 5.0f, 1.0f) + glm::vec3(0.01f, 0.0f, -0.015f) * float(i);
    const glm::mat4 turn = glm::rotate(glm::mat4(1.0f), glm::radians(0.05f * float(i)), glm::vec3(0, 1, 0));
    const glm::vec3 ahead = glm::vec3(turn * glm::vec4(glm::vec3(-0.6f, 0.0f, -5.0f) - glm::vec3(1.5f, 5.0f, 1.0f), 0.0f));
    return lookingAt(eye, eye + ahead, 20.0f);
  };
  const float texel = render::fitSunCascades(field().bounds(), kSunTravel, kMap, 4, cameraAt(0),
                                             float(kWidth) / float(kHeight))
                          .texelWorld[0];
  struct Run {
    double worstStep = 0.0, spread = 0.0;
    size_t drawn = 0;
  };
  const auto run = [&](bool snap) {
    Run r;
    double lo = 1e30, hi = -1e30;
    std::optional<double> previous;
    for (int i = 0; i < kFrames; ++i) {
      render::FrameSettings f = shadowView(cameraAt(i), 4, kMap);
      f.shadows.snapCascades = snap;
      const render::Frame frame = gpu.render(f);
      CHECK(nonFinite(frame) == 0);
      r.drawn += frame.sunMap == render::Frame::SunMap::drawn ||
                         frame.sunMap == render::Frame::SunMap::scrolled
                     ? 1
                     : 0;
      size_t lines = 0;
      const std::optional<double> x = edgeX(frame, f.camera, lines);
      REQUIRE(x);
      CHECK(lines == 40);
      if (previous) r.worstStep = std::max(r.worstStep, std::abs(*x - *previous));
      previous = x;
      lo = std::min(lo, *x);
      hi = std::max(hi, *x);
    }
    r.spread = hi - lo;
    return r;
  };
  const Run snapped = run(true);
  const Run unsnapped = run(false);
  MESSAGE("near cascade texel " << texel * 100.0f << " cm; edge x frame to frame, the most: snapped "
                                << snapped.worstStep * 100.0 << " cm (spread " << snapped.spread * 100.0
                                << " cm), unsnapped " << unsnapped.worstStep * 100.0 << " cm (spread "
                                << unsnapped.spread * 100.0 << " cm); maps drawn " << snapped.drawn
                                << " and " << unsnapped.drawn << " of " << kFrames);
  CHECK(snapped.worstStep < 0.5 * texel);
  CHECK(snapped.spread < 0.5 * texel);
  // The maps follow the camera, by whole texels: drawn again when it moved by one or more.
  CHECK(snapped.drawn > 0);
  CHECK(snapped.drawn < size_t(kFrames));
  CHECK(unsnapped.drawn == size_t(kFrames));

  // A camera that stays keeps the maps: drawn once per frame slot, then kept.
  const render::FrameSettings still = shadowView(cameraAt(0), 4, kMap);
  gpu.render(still);
  gpu.render(still);
  CHECK(gpu.render(still).sunMap == render::Frame::SunMap::kept);
  // One map over the scene stays put while the camera moves.
  gpu.render(shadowView(cameraAt(0), 1, kMap));
  gpu.render(shadowView(cameraAt(1), 1, kMap));
  CHECK(gpu.render(shadowView(cameraAt(2), 1, kMap)).sunMap == render::Frame::SunMap::kept);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("sun cascades: a moved camera scrolls the maps, and they equal maps drawn whole") {
  test::GpuSuite& gpu = cascadeGpu();
  gpu.setScene(field());
  constexpr uint32_t kMap = 512;
  // Half a metre along and across, and two degrees of turn: the splits stay, each map moves by
  // whole texels (tens in the near cascade).
  const scene::Camera before = lookingAt(kEye, kEye + glm::vec3(0.0f, -0.4f, -1.0f), 60.0f);
  const scene::Camera after =
      lookingAt(kEye + glm::vec3(0.4f, 0.0f, -0.5f),
                kEye + glm::vec3(0.4f, 0.0f, -0.5f) +
                    glm::vec3(glm::rotate(glm::mat4(1.0f), glm::radians(2.0f), glm::vec3(0, 1, 0)) *
                              glm::vec4(0.0f, -0.4f, -1.0f, 0.0f)),
                60.0f);
  const auto fitOf = [&](const scene::Camera& c) {
    return render::fitSunCascades(field().bounds(), kSunTravel, kMap, 4, c,
                                  float(kWidth) / float(kHeight));
  };
  const render::SunShadowFit a = fitOf(before), b = fitOf(after);
  for (uint32_t c = 0; c < 4; ++c) {
    CHECK(a.texelWorld[c] == b.texelWorld[c]);  // the same splits: a scroll, not a new fit
    CHECK(a.viewProjection[c] != b.viewProjection[c]);
  }
  // Both frame slots draw the first camera's maps; the next frame scrolls one of them.
  gpu.render(shadowView(before, 4, kMap));
  gpu.render(shadowView(before, 4, kMap));
  const render::Frame scrolled = gpu.render(shadowView(after, 4, kMap));
  CHECK(scrolled.sunMap == render::Frame::SunMap::scrolled);
  // The same view with the maps drawn whole (a scene set again is a new generation).
  gpu.setScene(field());
  const render::Frame whole = gpu.render(shadowView(after, 4, kMap));
  CHECK(whole.sunMap == render::Frame::SunMap::drawn);
  REQUIRE(scrolled.data.size() == whole.data.size());
  size_t surface = 0, differ = 0, shadowed = 0;
  for (size_t i = 0; i + 1 < whole.data.size(); i += 2) {
    if (whole.data[i + 1] < 0.0f) continue;  // no surface
    ++surface;
    shadowed += whole.data[i] < 0.5f ? 1 : 0;
    differ += std::abs(scrolled.data[i] - whole.data[i]) > 1e-6f ||
                      scrolled.data[i + 1] != whole.data[i + 1]
                  ? 1
                  : 0;
  }
  MESSAGE("scrolled maps against maps drawn whole: " << differ << " of " << surface
                                                     << " surface pixels differ (" << shadowed
                                                     << " in shadow)");
  CHECK(surface > size_t(kWidth) * kHeight / 2);
  CHECK(shadowed > 500);
  CHECK(differ == 0);
  CHECK(nonFinite(scrolled) == 0);
  CHECK(gpu.context->validationMessages.load() == 0);
}
