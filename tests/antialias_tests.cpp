// Anti-aliasing of `final` (shaders/antialias.comp), with validation on: a dark box seen from
// straight above on a bright floor, rotated so that its top face's edges cross the image at a
// known slant (10 degrees off the rows and the columns), where an unfiltered edge is a staircase.
//
// The stair-step metric: along the box's upper edge (nearly horizontal), each column's edge
// position is its coverage, the sum over the rows around the edge of how bright each pixel is
// between the box's luma (0) and the floor's (1). Without anti-aliasing every pixel is box or
// floor, so the position moves in whole pixels: a "1-pixel step" is a column where it moves by
// 0.75 px or more from its left neighbour. Filtering turns each step into a ramp over several
// columns. Also reported: the largest luma difference of two horizontal neighbours along the edge.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "image_compare.h"
#include "render/renderer.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using Gpu = test::GpuSuite;

Gpu& sharedGpu() {
  static Gpu gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 256;
constexpr uint32_t kHeight = 192;
constexpr float kSlantDegrees = 10.0f;
constexpr float kHalfSide = 1.5f;  // the box's top face is 3 m square, 1 m above the floor

scene::Scene slantedBoxScene() {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.8f), 0.0f, 1.0f});
  s.materials.push_back({"box", glm::vec3(0.02f), 0.0f, 1.0f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(40.0f, 1.0f, 40.0f))});
  glm::mat4 box = glm::rotate(glm::mat4(1.0f), glm::radians(kSlantDegrees), glm::vec3(0.0f, 1.0f, 0.0f));
  box = glm::translate(box, glm::vec3(0.0f, 0.5f, 0.0f));
  s.instances.push_back({1, 1, glm::scale(box, glm::vec3(2.0f * kHalfSide, 1.0f, 2.0f * kHalfSide))});
  s.sun.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  s.sun.intensity = 2.0f;
  s.ambient = glm::vec3(0.05f);
  return s;
}

// Straight down at the box: its top face is parallel to the image, so its edges keep their slant,
// and its sides face away from the eye.
scene::Camera topDown() {
  scene::Camera c;
  c.eye = glm::vec3(0.0f, 6.0f, 0.0f);
  c.target = glm::vec3(0.0f);
  c.up = glm::vec3(0.0f, 0.0f, -1.0f);
  c.fovYDegrees = 60.0f;
  c.nearPlane = 0.1f;
  c.farPlane = 50.0f;
  return c;
}

render::FrameSettings frameOf(render::Antialias antialias, render::Technique technique,
                              render::Target target = render::Target::Final) {
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera = topDown();
  f.target = target;
  f.technique = technique;
  f.markers = false;
  f.antialias = antialias;
  return f;
}

glm::vec2 pixelOf(const scene::Camera& camera, glm::vec3 point) {
  glm::vec4 clip = scene::projectionMatrix(camera, float(kWidth) / float(kHeight)) *
                   scene::viewMatrix(camera) * glm::vec4(point, 1.0f);
  return (glm::vec2(clip) / clip.w * 0.5f + 0.5f) * glm::vec2(kWidth, kHeight);
}

float lumaOf(const std::vector<uint8_t>& rgba, int x, int y) {
  const size_t i = (size_t(y) * kWidth + size_t(x)) * 4;
  return (0.299f * rgba[i] + 0.587f * rgba[i + 1] + 0.114f * rgba[i + 2]) / 255.0f;
}

struct StairSteps {
  int columns = 0;      // columns measured along the edge
  int steps = 0;        // columns where the edge position moves by >= 0.75 px
  float largestMove = 0.0f;  // px
  float largestNeighbourDifference = 0.0f;  // luma, horizontal neighbours within 2 rows of the edge
};

// The box's upper edge in the image: between the projections of the top face's two corners with
// the smallest y, away from its ends (where the other edges meet it).
StairSteps measureUpperEdge(const std::vector<uint8_t>& rgba) {
  const scene::Camera camera = topDown();
  std::vector<glm::vec2> corners;
  for (float sx : {-1.0f, 1.0f}) {
    for (float sz : {-1.0f, 1.0f}) {
      glm::vec4 local(sx * kHalfSide, 1.0f, sz * kHalfSide, 1.0f);
      glm::vec3 world = glm::rotate(glm::mat4(1.0f), glm::radians(kSlantDegrees), glm::vec3(0.0f, 1.0f, 0.0f)) * local;
      corners.push_back(pixelOf(camera, world));
    }
  }
  std::sort(corners.begin(), corners.end(), [](glm::vec2 a, glm::vec2 b) { return a.y < b.y; });
  glm::vec2 a = corners[0], b = corners[1];
  if (a.x > b.x) std::swap(a, b);
  const float slope = (b.y - a.y) / (b.x - a.x);
  const int first = int(std::ceil(a.x + 0.1f * (b.x - a.x)));
  const int last = int(std::floor(b.x - 0.1f * (b.x - a.x)));
  StairSteps result;
  float previous = 0.0f;
  for (int x = first; x <= last; ++x) {
    const float edgeY = a.y + slope * (float(x) + 0.5f - a.x);
    const int top = int(std::floor(edgeY)) - 4;
    const int bottom = int(std::floor(edgeY)) + 4;
    REQUIRE(top >= 0);
    REQUIRE(bottom < int(kHeight));
    // Floor above the edge (smaller y), box below; normalise by this column's own two.
    const float bright = lumaOf(rgba, x, top);
    const float dark = lumaOf(rgba, x, bottom);
    REQUIRE(bright - dark > 0.5f);  // a high-contrast edge
    // The edge's row: the window's top plus the floor's coverage of the window (in rows).
    float position = float(top);
    for (int y = top; y <= bottom; ++y) {
      position += std::clamp((lumaOf(rgba, x, y) - dark) / (bright - dark), 0.0f, 1.0f);
      if (x < last && std::abs(float(y) - edgeY) <= 2.0f) {
        result.largestNeighbourDifference =
            std::max(result.largestNeighbourDifference, std::abs(lumaOf(rgba, x + 1, y) - lumaOf(rgba, x, y)));
      }
    }
    if (x > first) {
      const float move = std::abs(position - previous);
      result.largestMove = std::max(result.largestMove, move);
      if (move >= 0.75f) ++result.steps;
    }
    previous = position;
    ++result.columns;
  }
  return result;
}

// Pixels within `reach` pixels (Chebyshev) of a luma step of more than `step` between 4-neighbours.
std::vector<bool> nearEdges(const std::vector<uint8_t>& rgba, float step, int reach) {
  std::vector<bool> edge(size_t(kWidth) * kHeight, false);
  for (int y = 0; y < int(kHeight); ++y) {
    for (int x = 0; x < int(kWidth); ++x) {
      const float l = lumaOf(rgba, x, y);
      const bool right = x + 1 < int(kWidth) && std::abs(lumaOf(rgba, x + 1, y) - l) > step;
      const bool down = y + 1 < int(kHeight) && std::abs(lumaOf(rgba, x, y + 1) - l) > step;
      if (!right && !down) continue;
      for (int dy = -reach; dy <= reach + 1; ++dy) {
        for (int dx = -reach; dx <= reach + 1; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx >= 0 && ny >= 0 && nx < int(kWidth) && ny < int(kHeight)) edge[size_t(ny) * kWidth + nx] = true;
        }
      }
    }
  }
  return edge;
}

}  // namespace

TEST_CASE("antialias: a slanted high-contrast edge loses its stair steps, in every technique; the rest is unchanged") {
  Gpu& gpu = sharedGpu();
  gpu.setScene(slantedBoxScene());
  for (render::Technique technique : render::allTechniques()) {
    CAPTURE(render::techniqueName(technique));
    const render::Frame plain = gpu.render(frameOf(render::Antialias::None, technique));
    const render::Frame smooth = gpu.render(frameOf(render::Antialias::Fxaa, technique));
    const StairSteps before = measureUpperEdge(plain.rgba);
    const StairSteps after = measureUpperEdge(smooth.rgba);
    MESSAGE(render::techniqueName(technique) << ": " << before.columns << " columns along a "
            << kSlantDegrees << " degree edge; 1-pixel steps " << before.steps << " -> " << after.steps
            << ", largest move " << before.largestMove << " -> " << after.largestMove
            << " px, largest neighbour difference " << before.largestNeighbourDifference << " -> "
            << after.largestNeighbourDifference);
    // The staircase is there without anti-aliasing: about one step per 1/tan(10 deg) = 5.7 columns.
    CHECK(before.steps >= before.columns / 8);
    CHECK(before.largestMove >= 0.95f);
    // ... and at least 4 times fewer steps with it (measured: none), the edge moving by at most
    // half a pixel from column to column (measured: 0.33 px; the true slope is 0.18 px a column),
    // and neighbours along the edge at least twice as close (measured: 0.67 -> 0.20).
    CHECK(after.steps * 4 <= before.steps);
    CHECK(after.largestMove <= 0.5f);
    CHECK(after.largestNeighbourDifference <= 0.5f * before.largestNeighbourDifference);

    // Away from edges (more than 2 px from a luma step over 32/255 in the plain image) the
    // filter changes nothing: at most 1/255 (it writes such pixels back as they were).
    const std::vector<bool> edges = nearEdges(plain.rgba, 32.0f / 255.0f, 2);
    size_t nearCount = 0, changedAway = 0;
    int worstAway = 0;
    for (size_t p = 0; p < edges.size(); ++p) {
      if (edges[p]) {
        ++nearCount;
        continue;
      }
      int worst = 0;
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(plain.rgba[p * 4 + c]) - int(smooth.rgba[p * 4 + c])));
      worstAway = std::max(worstAway, worst);
      if (worst > 1) ++changedAway;
    }
    MESSAGE("pixels near edges: " << nearCount << " of " << edges.size() << "; largest difference away from them "
                                  << worstAway << "/255");
    CHECK(nearCount * 10 < edges.size());  // the comparison covers most of the picture
    CHECK(changedAway == 0);

    // Raw output is never filtered, and finite.
    render::FrameSettings raw = frameOf(render::Antialias::Fxaa, technique);
    raw.raw = true;
    const render::Frame rawSmooth = gpu.render(raw);
    raw.antialias = render::Antialias::None;
    const render::Frame rawPlain = gpu.render(raw);
    size_t nonFinite = 0;
    for (float v : rawSmooth.data) nonFinite += std::isfinite(v) ? 0 : 1;
    CHECK(nonFinite == 0);
    CHECK(rawSmooth.data == rawPlain.data);
    CHECK(gpu.context->validationMessages.load() == 0);
  }
}

TEST_CASE("antialias: data views, light-volumes and raw output are unchanged byte for byte") {
  Gpu& gpu = sharedGpu();
  scene::Scene s = slantedBoxScene();
  s.lights = {{glm::vec3(1.8f, 1.2f, 0.5f), 2.0f, glm::vec3(1.0f, 0.6f, 0.2f), 4.0f, 1.0f}};
  gpu.setScene(s);
  size_t compared = 0;
  for (uint32_t i = 0; i < render::kTargetNames.size(); ++i) {
    const auto target = static_cast<render::Target>(i);
    CAPTURE(render::targetName(target));
    for (bool raw : {false, true}) {
      if (target == render::Target::Final && !raw) continue;  // the one image it filters
      if (render::isLabel(target) && !raw) continue;  // labels are raw only (label_tests.cpp)
      render::FrameSettings f = frameOf(render::Antialias::Fxaa, render::Technique::Clustered, target);
      f.width = 96;
      f.height = 64;
      f.raw = raw;
      const render::Frame on = gpu.render(f);
      f.antialias = render::Antialias::None;
      const render::Frame off = gpu.render(f);
      CHECK(on.rgba == off.rgba);
      CHECK(on.data == off.data);
      CHECK((raw ? on.data.size() : on.rgba.size()) == size_t(f.width) * f.height * 4);
      // Only final (8-bit) has an anti-aliasing pass.
      for (const render::PassTiming& pass : on.passes) CHECK(pass.name != "antialias");
      ++compared;
    }
  }
  CHECK(compared == 2 * render::kTargetNames.size() - 1 - 3);  // final and the labels: raw only
  // And final does run it.
  render::FrameSettings f = frameOf(render::Antialias::Fxaa, render::Technique::Clustered);
  f.width = 96;
  f.height = 64;
  const render::Frame final = gpu.render(f);
  CHECK(std::any_of(final.passes.begin(), final.passes.end(),
                    [](const render::PassTiming& p) { return p.name == "antialias"; }));
  CHECK(gpu.context->validationMessages.load() == 0);
}
