// The label targets (instance-id, semantic-id, material-id) against the C++ reference's first ray
// hits, and the frame's intrinsics and pose against where a known box lands in the id mask
// (lavapipe in CI, validation on).
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "render/reference.h"
#include "scene/camera.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using Gpu = test::GpuSuite;

Gpu& sharedGpu() {
  static Gpu gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 160;
constexpr uint32_t kHeight = 120;

// A floor (object 1) and seven boxes (objects 10..16) at known places: some touching, one
// rotated, one behind another, one hidden under the floor, two sharing a semantic class.
scene::Scene boxesScene() {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.7f), 0.0f, 0.8f});
  for (int i = 0; i < 4; ++i) s.materials.push_back({"box", glm::vec3(0.2f + 0.2f * i), 0.0f, 0.5f});
  scene::Instance floor{0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(20.0f, 1.0f, 20.0f))};
  floor.object = 1;
  floor.semantic = 1;
  s.instances.push_back(floor);
  const glm::vec3 places[] = {{-2.0f, 0.5f, 0.0f}, {-0.9f, 0.5f, 0.0f}, {0.6f, 0.75f, -0.5f},
                              {2.2f, 0.5f, 0.8f},  {0.0f, 0.4f, -3.0f}, {1.4f, 1.6f, -2.2f},
                              {0.0f, -2.0f, 0.0f}};
  for (uint32_t i = 0; i < 7; ++i) {
    glm::mat4 m = glm::translate(glm::mat4(1.0f), places[i]);
    if (i == 2) m = glm::rotate(m, glm::radians(35.0f), glm::vec3(0.3f, 1.0f, 0.1f));
    m = glm::scale(m, i == 2 ? glm::vec3(1.0f, 1.5f, 0.8f) : glm::vec3(0.9f));
    scene::Instance box{1, 1 + i % 4, m};
    box.object = 10 + i;
    box.semantic = i < 2 ? 7 : 8 + i;
    s.instances.push_back(box);
  }
  s.sun.direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.2f));
  return s;
}

scene::Camera view() {
  scene::Camera c;
  c.eye = glm::vec3(1.5f, 3.5f, 6.0f);
  c.target = glm::vec3(0.0f, 0.5f, -0.5f);
  c.fovYDegrees = 50.0f;
  c.nearPlane = 0.1f;
  c.farPlane = 40.0f;
  return c;
}

render::FrameSettings labelFrame(render::Target target) {
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera = view();
  f.target = target;
  f.raw = true;
  f.markers = false;
  return f;
}

// Frame::data's uint32 bit patterns: object, semantic, material, covered per pixel.
std::vector<glm::uvec4> labelsOf(const render::Frame& frame) {
  std::vector<glm::uvec4> out(size_t(frame.width) * frame.height);
  REQUIRE(frame.data.size() == out.size() * 4);
  for (size_t i = 0; i < out.size(); ++i) {
    for (int c = 0; c < 4; ++c) out[i][c] = std::bit_cast<uint32_t>(frame.data[i * 4 + c]);
  }
  return out;
}

}  // namespace

TEST_CASE("labels: every pixel's ids are the reference's first hit; silhouettes hold a neighbour's") {
  Gpu& gpu = sharedGpu();
  const scene::Scene s = boxesScene();
  gpu.setScene(s);
  const render::Frame frame = gpu.render(labelFrame(render::Target::InstanceId));
  const std::vector<glm::uvec4> labels = labelsOf(frame);
  const std::vector<glm::uvec4> reference = render::referenceLabels(s, labelFrame(render::Target::InstanceId));
  REQUIRE(reference.size() == labels.size());

  size_t mismatches = 0, silhouette = 0, wrongNeighbour = 0;
  std::vector<uint32_t> seen;
  for (uint32_t y = 0; y < kHeight; ++y) {
    for (uint32_t x = 0; x < kWidth; ++x) {
      const size_t i = size_t(y) * kWidth + x;
      const glm::uvec4 got = labels[i], want = reference[i];
      if (std::find(seen.begin(), seen.end(), got.x) == seen.end()) seen.push_back(got.x);
      // Where the ids agree the other labels must too: one draw wrote all three.
      if (got.x == want.x) {
        CHECK(got == want);
        continue;
      }
      ++mismatches;
      // Allowed only on a silhouette: a pixel whose reference neighbours differ, and then the
      // GPU's id must be one of them (the rasteriser and the ray disagree only at the edge).
      bool edge = false, neighbour = false;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = int(x) + dx, ny = int(y) + dy;
          if (nx < 0 || ny < 0 || nx >= int(kWidth) || ny >= int(kHeight)) continue;
          const uint32_t other = reference[size_t(ny) * kWidth + nx].x;
          edge = edge || other != want.x;
          neighbour = neighbour || other == got.x;
        }
      }
      if (edge) ++silhouette;
      if (!neighbour) ++wrongNeighbour;
    }
  }
  std::sort(seen.begin(), seen.end());
  INFO("mismatched pixels: ", mismatches, " (on silhouettes: ", silhouette, ")");
  // The floor, six visible boxes and the background; the box under the floor never shows.
  CHECK(seen == std::vector<uint32_t>{0, 1, 10, 11, 12, 13, 14, 15});
  CHECK(mismatches == silhouette);
  CHECK(wrongNeighbour == 0);
  CHECK(mismatches < labels.size() / 100);
  // Stable: the same frame again is the same labels, and so is every label target (one pass).
  CHECK(labelsOf(gpu.render(labelFrame(render::Target::InstanceId))) == labels);
  CHECK(labelsOf(gpu.render(labelFrame(render::Target::SemanticId))) == labels);
  CHECK(labelsOf(gpu.render(labelFrame(render::Target::MaterialId))) == labels);
  // Not raw: refused (the contract of render::Target::InstanceId).
  render::FrameSettings notRaw = labelFrame(render::Target::InstanceId);
  notRaw.raw = false;
  CHECK_THROWS_AS(gpu.render(notRaw), std::invalid_argument);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("labels: a box's projected corners bound its pixels in the id mask") {
  Gpu& gpu = sharedGpu();
  const scene::Scene s = boxesScene();
  gpu.setScene(s);
  const render::FrameSettings f = labelFrame(render::Target::InstanceId);
  const std::vector<glm::uvec4> labels = labelsOf(gpu.render(f));
  const scene::Intrinsics k = scene::intrinsicsOf(f.camera, kWidth, kHeight);
  const glm::mat4 cameraFromWorld = glm::inverse(scene::worldFromCamera(f.camera));
  // Box 13 stands in front, clear of the others: the whole of it is in view (box 10's right
  // side is behind box 11 from this eye).
  for (uint32_t object : {13u}) {
    CAPTURE(object);
    const glm::mat4& model = s.instances[object - 9].transform;
    glm::vec2 lo(1e9f), hi(-1e9f);
    for (int corner = 0; corner < 8; ++corner) {
      const glm::vec3 local((corner & 1) ? 0.5f : -0.5f, (corner & 2) ? 0.5f : -0.5f,
                            (corner & 4) ? 0.5f : -0.5f);
      const glm::vec3 c = glm::vec3(cameraFromWorld * model * glm::vec4(local, 1.0f));
      const glm::vec2 uv(k.fx * c.x / c.z + k.cx, k.fy * c.y / c.z + k.cy);
      lo = glm::min(lo, uv);
      hi = glm::max(hi, uv);
    }
    // The mask's extent: its outermost pixel centres.
    glm::vec2 maskLo(1e9f), maskHi(-1e9f);
    for (uint32_t y = 0; y < kHeight; ++y) {
      for (uint32_t x = 0; x < kWidth; ++x) {
        if (labels[size_t(y) * kWidth + x].x != object) continue;
        maskLo = glm::min(maskLo, glm::vec2(x + 0.5f, y + 0.5f));
        maskHi = glm::max(maskHi, glm::vec2(x + 0.5f, y + 0.5f));
      }
    }
    INFO("projected [", lo.x, ", ", lo.y, "] - [", hi.x, ", ", hi.y, "], mask centres [", maskLo.x,
         ", ", maskLo.y, "] - [", maskHi.x, ", ", maskHi.y, "]");
    // A pixel is in the mask when its centre is inside the projection: the outermost centres lie
    // within one pixel inside the projected extremes (0.5 px on average), never outside them
    // (beyond a rounding margin).
    for (int a = 0; a < 2; ++a) {
      CHECK(maskLo[a] >= lo[a] - 0.01f);
      CHECK(maskLo[a] - lo[a] <= 1.0f);
      CHECK(maskHi[a] <= hi[a] + 0.01f);
      CHECK(hi[a] - maskHi[a] <= 1.0f);
    }
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("labels: the objects of one asset drawn as instanced draws keep their own ids") {
  // 36 boxes of one mesh and one material, one after another in the instance buffer: the G-buffer,
  // shadow and label passes draw them as one instanced draw (render::InstancedDraws). Each box
  // must still be itself: its own transform (where the reference sees it) and its own id.
  Gpu& gpu = sharedGpu();
  scene::Scene s;
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"box", glm::vec3(0.6f), 0.0f, 0.5f});
  for (uint32_t i = 0; i < 36; ++i) {
    const glm::vec3 at(-2.5f + float(i % 6), 0.3f * float(i % 3), -2.5f + float(i / 6));
    scene::Instance box{0, 0, glm::scale(glm::translate(glm::mat4(1.0f), at), glm::vec3(0.6f))};
    box.object = 100 + i;
    box.semantic = i % 5;
    s.instances.push_back(box);
  }
  gpu.setScene(s);
  render::FrameSettings f = labelFrame(render::Target::InstanceId);
  f.camera.eye = glm::vec3(0.5f, 6.0f, 5.0f);
  f.camera.target = glm::vec3(0.0f, 0.0f, -0.5f);
  const std::vector<glm::uvec4> labels = labelsOf(gpu.render(f));
  const std::vector<glm::uvec4> reference = render::referenceLabels(s, f);
  size_t mismatches = 0, interior = 0;
  std::vector<uint32_t> seen;
  for (uint32_t y = 1; y + 1 < kHeight; ++y) {
    for (uint32_t x = 1; x + 1 < kWidth; ++x) {
      const size_t i = size_t(y) * kWidth + x;
      if (labels[i].x != 0 && std::find(seen.begin(), seen.end(), labels[i].x) == seen.end()) {
        seen.push_back(labels[i].x);
      }
      if (labels[i] == reference[i]) continue;
      ++mismatches;
      bool edge = false;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) edge = edge || reference[i + dy * int(kWidth) + dx].x != reference[i].x;
      }
      if (!edge) ++interior;
    }
  }
  INFO("mismatches: ", mismatches);
  CHECK(interior == 0);
  CHECK(seen.size() == 36);
  CHECK(gpu.context->validationMessages.load() == 0);
}
