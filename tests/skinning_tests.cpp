// Skinning and morphing on the GPU (render/skinning.h), judged against the same meshes posed on
// the CPU and rendered unposed (tests/posed_scenes.h), on lavapipe with validation on: a bar bent
// by two joints, a grid with two morph targets, a 300-joint skin, skin and morph on one instance,
// the sun's shadow and the instance-id label of the posed mesh, the same pose twice, and what an
// unposed scene keeps.
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <memory>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test_support.h"
#include "posed_scenes.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

test::GpuSuite& sharedGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

constexpr uint32_t kWidth = 160;
constexpr uint32_t kHeight = 120;
// Posed on the GPU and on the CPU, the vertices differ by float rounding only (the blend's sums in
// another order): a pixel on a silhouette or a shadow's edge may flip. At most this share of the
// pixels may differ by more than kTolerance (of 255) in any channel.
constexpr double kFlipShare = 0.004;
constexpr int kTolerance = 2;

constexpr float kBarLength = 4.0f;

// Pixels whose channels differ by more than `tolerance` (8-bit frames).
size_t differing(const render::Frame& a, const render::Frame& b, int tolerance = kTolerance) {
  const auto pa = a.pixels(), pb = b.pixels();
  REQUIRE(pa.size() == pb.size());
  size_t n = 0;
  for (size_t i = 0; i < pa.size(); i += 4) {
    for (size_t c = 0; c < 3; ++c) {
      if (std::abs(int(pa[i + c]) - int(pb[i + c])) > tolerance) {
        ++n;
        break;
      }
    }
  }
  return n;
}

double share(size_t pixels) { return double(pixels) / double(kWidth * kHeight); }

// A floor, a pillar (so that the scene's bounds, and the sun's map fitted to them, do not depend
// on where the posed mesh goes) and `mesh` at `place`, skinned by skin 0 when `skinned`.
scene::Scene stage(const scene::Mesh& mesh, const glm::mat4& place, bool skinned) {
  scene::Scene s;
  s.meshes = {scene::makePlane(4.0f), scene::makeCube(), mesh};
  s.materials.push_back({"floor", glm::vec3(0.7f), 0.0f, 0.8f});
  s.materials.push_back({"pillar", glm::vec3(0.3f, 0.4f, 0.6f), 0.0f, 0.6f});
  scene::Material posed{"posed", glm::vec3(0.9f, 0.45f, 0.15f), 0.0f, 0.45f};
  posed.doubleSided = true;
  s.materials.push_back(posed);
  scene::Instance floor{0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(24.0f, 1.0f, 24.0f))};
  floor.object = 1;
  s.instances.push_back(floor);
  scene::Instance pillar{1, 1, glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-5.0f, 5.0f, -6.0f)),
                                          glm::vec3(0.6f, 10.0f, 0.6f))};
  pillar.object = 2;
  s.instances.push_back(pillar);
  scene::Instance instance{2, 2, place};
  instance.object = 3;
  if (skinned) instance.skin = 0;
  s.instances.push_back(instance);
  s.sun.direction = glm::normalize(glm::vec3(-0.35f, -1.0f, -0.25f));
  return s;
}

render::FrameSettings frameOf(glm::vec3 eye, glm::vec3 target) {
  render::FrameSettings f;
  f.width = kWidth;
  f.height = kHeight;
  f.camera.eye = eye;
  f.camera.target = target;
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 60.0f;
  f.markers = false;
  f.antialias = render::Antialias::None;
  return f;
}

std::shared_ptr<render::ScenePose> poseOf(uint32_t instance, std::vector<glm::mat4> joints,
                                          std::vector<float> weights = {}) {
  auto pose = std::make_shared<render::ScenePose>();
  pose->poses.push_back({instance, std::move(joints), std::move(weights)});
  return pose;
}

bool hasPass(const render::Frame& f, const char* name) {
  return std::any_of(f.passes.begin(), f.passes.end(), [&](const auto& p) { return p.name == name; });
}

const glm::mat4 kBarPlace = glm::translate(glm::mat4(1.0f), glm::vec3(-1.5f, 2.6f, 0.0f));

// The GPU's posed render of `mesh` (at `place`, with `joints`/`weights`) against the CPU-posed
// copy's, and against the rest pose's; with `settings` (sun shadows, a raw target, ...).
struct Comparison {
  render::Frame gpu, cpu, rest;
};
Comparison compare(const scene::Mesh& mesh, const glm::mat4& place, const std::vector<glm::mat4>& joints,
                   const std::vector<float>& weights, render::FrameSettings f,
                   uint32_t barJoints = 0) {
  test::GpuSuite& g = sharedGpu();
  Comparison c;
  scene::Scene posedScene = stage(mesh, place, !joints.empty());
  if (barJoints > 0) test::addBarSkin(posedScene, kBarLength * (barJoints >= 100 ? 1.5f : 1.0f), barJoints);
  g.setScene(posedScene);
  c.rest = g.render(f);
  f.pose = poseOf(2, joints, weights);
  c.gpu = g.render(f);
  CHECK(hasPass(c.gpu, "skin"));
  f.pose = nullptr;
  g.setScene(stage(test::posedOnCpu(mesh, joints, weights), place, false));
  c.cpu = g.render(f);
  CHECK_FALSE(hasPass(c.cpu, "skin"));
  return c;
}

}  // namespace

TEST_CASE("skinning: a bar bent by two joints on the GPU equals its copy posed on the CPU") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  const std::vector<glm::mat4> joints = test::barPose(kBarLength, {0.15f, 1.1f});
  const Comparison c = compare(bar, kBarPlace, joints, {}, frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f}), 2);
  const size_t flips = differing(c.gpu, c.cpu);
  const size_t moved = differing(c.gpu, c.rest);
  MESSAGE("posed vs CPU copy: " << flips << " pixels differ; posed vs rest: " << moved);
  CHECK(share(flips) <= kFlipShare);
  CHECK(share(moved) >= 0.02);  // the pose moved the bar
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: morph targets (positions, normals, tangents) equal the CPU's") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh grid = test::makeMorphGrid(3.0f, 24);
  const glm::mat4 place = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 1.5f, 0.0f));
  render::FrameSettings f = frameOf({0.0f, 5.0f, 4.5f}, {0.0f, 1.8f, 0.0f});
  const Comparison c = compare(grid, place, {}, {0.7f, -0.6f}, f);
  const size_t flips = differing(c.gpu, c.cpu);
  const size_t moved = differing(c.gpu, c.rest);
  MESSAGE("morphed vs CPU copy: " << flips << " pixels differ; morphed vs rest: " << moved);
  CHECK(share(flips) <= kFlipShare);
  CHECK(share(moved) >= 0.02);
  // The normals and tangents themselves (the normal view, raw).
  f.target = render::Target::Normal;
  f.raw = true;
  const Comparison n = compare(grid, place, {}, {0.7f, -0.6f}, f);
  double worst = 0.0;
  size_t surface = 0;
  for (size_t i = 0; i < n.gpu.data.size(); i += 4) {
    if (n.cpu.data[i] == 0.0f && n.cpu.data[i + 1] == 0.0f && n.cpu.data[i + 2] == 0.0f) continue;
    ++surface;
    for (size_t k = 0; k < 3; ++k) worst = std::max(worst, double(std::abs(n.gpu.data[i + k] - n.cpu.data[i + k])));
  }
  MESSAGE("normal view: worst component difference " << worst << " over " << surface << " pixels");
  CHECK(surface > 2000);
  // Silhouette pixels may show another surface; the rest agree to the G-buffer's precision.
  size_t far = 0;
  for (size_t i = 0; i < n.gpu.data.size(); i += 4) {
    for (size_t k = 0; k < 3; ++k) {
      if (std::abs(n.gpu.data[i + k] - n.cpu.data[i + k]) > 0.01f) {
        ++far;
        break;
      }
    }
  }
  CHECK(share(far) <= kFlipShare);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: a skin of 300 joints (past 256) curls as on the CPU") {
  test::GpuSuite& g = sharedGpu();
  const float length = kBarLength * 1.5f;
  const uint32_t joints = 300;
  const scene::Mesh bar = test::makeBar(length, 0.12f, 2 * joints + 1, joints);
  std::vector<float> angles(joints);
  for (uint32_t k = 0; k < joints; ++k) angles[k] = k == 0 ? 0.0f : 0.016f;
  const std::vector<glm::mat4> pose = test::barPose(length, angles);
  const glm::mat4 place = glm::translate(glm::mat4(1.0f), glm::vec3(-1.0f, 1.2f, 0.0f));
  const Comparison c = compare(bar, place, pose, {}, frameOf({0.5f, 3.5f, 8.0f}, {0.5f, 2.5f, 0.0f}), joints);
  const size_t flips = differing(c.gpu, c.cpu);
  const size_t moved = differing(c.gpu, c.rest);
  MESSAGE("300 joints: " << flips << " pixels differ from the CPU copy; " << moved << " from rest");
  CHECK(share(flips) <= kFlipShare);
  CHECK(share(moved) >= 0.02);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: one instance both skinned and morphed") {
  test::GpuSuite& g = sharedGpu();
  scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  scene::MorphTarget swell{"swell", {}, {}, {}};
  for (const scene::Vertex& v : bar.vertices) {
    swell.positions.push_back(v.normal * (0.3f * v.position.x / kBarLength));
  }
  bar.morphTargets = {swell};
  bar.morphWeights = {0.0f};
  const std::vector<glm::mat4> joints = test::barPose(kBarLength, {-0.2f, 0.9f});
  const Comparison c = compare(bar, kBarPlace, joints, {0.8f}, frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f}), 2);
  const size_t flips = differing(c.gpu, c.cpu);
  MESSAGE("skinned and morphed: " << flips << " pixels differ from the CPU copy");
  CHECK(share(flips) <= kFlipShare);
  // Skinned alone (the weight left at the mesh's default, 0) is another picture.
  test::GpuSuite& gg = sharedGpu();
  scene::Scene s = stage(bar, kBarPlace, true);
  test::addBarSkin(s, kBarLength, 2);
  gg.setScene(s);
  render::FrameSettings f = frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f});
  f.pose = poseOf(2, joints);
  CHECK(share(differing(gg.render(f), c.gpu)) >= 0.005);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: the sun's shadow and the instance-id label see the posed mesh") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  const std::vector<glm::mat4> joints = test::barPose(kBarLength, {0.1f, 1.3f});
  render::FrameSettings f = frameOf({1.0f, 6.5f, 6.5f}, {0.5f, 1.0f, 0.0f});
  f.shadows.sun = true;
  f.shadows.mapSize = 1024;
  const Comparison c = compare(bar, kBarPlace, joints, {}, f, 2);
  const size_t flips = differing(c.gpu, c.cpu);
  const size_t moved = differing(c.gpu, c.rest);
  MESSAGE("with the sun's shadow: " << flips << " pixels differ from the CPU copy; " << moved << " from rest");
  CHECK(share(flips) <= kFlipShare);
  CHECK(share(moved) >= 0.02);

  f.target = render::Target::InstanceId;
  f.raw = true;
  const Comparison ids = compare(bar, kBarPlace, joints, {}, f, 2);
  size_t mismatched = 0, bar3 = 0, bar3Rest = 0;
  for (size_t i = 0; i < ids.gpu.data.size(); i += 4) {
    const uint32_t a = std::bit_cast<uint32_t>(ids.gpu.data[i]);
    const uint32_t b = std::bit_cast<uint32_t>(ids.cpu.data[i]);
    mismatched += a != b ? 1 : 0;
    bar3 += a == 3 ? 1 : 0;
    bar3Rest += std::bit_cast<uint32_t>(ids.rest.data[i]) == 3 ? 1 : 0;
  }
  MESSAGE("instance-id: " << mismatched << " pixels differ; the bar covers " << bar3 << " posed, "
                          << bar3Rest << " at rest");
  CHECK(bar3 > 300);
  CHECK(share(mismatched) <= kFlipShare);
  CHECK(bar3 != bar3Rest);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: the same pose gives the same bytes; a pose that does not fit is refused") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  scene::Scene s = stage(bar, kBarPlace, true);
  test::addBarSkin(s, kBarLength, 2);
  g.setScene(s);
  render::FrameSettings f = frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f});
  f.shadows.sun = true;
  f.shadows.mapSize = 512;
  f.pose = poseOf(2, test::barPose(kBarLength, {0.0f, 0.8f}));
  const render::Frame a = g.render(f);
  const render::Frame again = g.render(f);  // the same pose object: nothing posed again
  CHECK_FALSE(hasPass(again, "skin"));
  CHECK(std::ranges::equal(a.pixels(), again.pixels()));
  f.pose = poseOf(2, test::barPose(kBarLength, {0.0f, -0.5f}));
  const render::Frame b = g.render(f);
  CHECK(hasPass(b, "skin"));
  CHECK(share(differing(a, b)) >= 0.01);
  f.pose = poseOf(2, test::barPose(kBarLength, {0.0f, 0.8f}));  // equal to the first, a new object
  const render::Frame a2 = g.render(f);
  CHECK(std::ranges::equal(a.pixels(), a2.pixels()));

  // Refused, and the scene keeps the pose it had.
  f.pose = poseOf(2, test::barPose(kBarLength, {0.0f, 0.3f, 0.2f}));  // three joints; the skin has two
  CHECK_THROWS_WITH_AS(g.render(f), doctest::Contains("joint matrices; its skin has 2"),
                       std::invalid_argument);
  f.pose = poseOf(1, test::barPose(kBarLength, {0.0f, 0.3f}));  // the pillar is not skinned
  CHECK_THROWS_WITH_AS(g.render(f), doctest::Contains("not skinned or morphed"), std::invalid_argument);
  auto bad = poseOf(2, test::barPose(kBarLength, {0.0f, 0.3f}));
  bad->poses[0].joints[1][3][0] = std::nanf("");
  f.pose = bad;
  CHECK_THROWS_WITH_AS(g.render(f), doctest::Contains("not finite"), std::invalid_argument);
  f.pose = nullptr;  // as last drawn
  CHECK(std::ranges::equal(a.pixels(), g.render(f).pixels()));
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: an unposed scene has no pre-pass and no posed memory") {
  test::GpuSuite& g = sharedGpu();
  // Many vertices, so that memory (allocated in blocks of a MiB) tells the scenes apart.
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 20001, 2);
  scene::Scene plain = stage(bar, kBarPlace, false);  // the same mesh, its skin unused
  scene::Mesh unskinned = bar;
  unskinned.joints.clear();
  unskinned.weights.clear();
  g.setScene(stage(unskinned, kBarPlace, false));
  const uint64_t bytesUnskinned = g.renderer->sceneBytes(g.scene);
  render::FrameSettings f = frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f});
  const render::Frame base = g.render(f);
  CHECK_FALSE(hasPass(base, "skin"));
  // A skinned mesh drawn by an instance without a skin is not posed either, and costs the same
  // geometry (its joints and weights are not uploaded).
  g.setScene(plain);
  CHECK(g.renderer->sceneBytes(g.scene) == bytesUnskinned);
  const render::Frame same = g.render(f);
  CHECK_FALSE(hasPass(same, "skin"));
  CHECK(std::ranges::equal(base.pixels(), same.pixels()));
  // An empty pose changes nothing.
  f.pose = std::make_shared<render::ScenePose>();
  const render::Frame empty = g.render(f);
  CHECK_FALSE(hasPass(empty, "skin"));
  CHECK(std::ranges::equal(base.pixels(), empty.pixels()));
  // The skinned scene holds more: the bar's posed region, its influences and pose.
  scene::Scene skinned = stage(bar, kBarPlace, true);
  test::addBarSkin(skinned, kBarLength, 2);
  g.setScene(skinned);
  CHECK(g.renderer->sceneBytes(g.scene) > bytesUnskinned);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: the G-buffer rasterised in compute draws the posed mesh too") {
  test::GpuSuite& g = sharedGpu();
  g.renderer->setGBufferPath(render::GBufferPath::Compute);
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  const std::vector<glm::mat4> joints = test::barPose(kBarLength, {0.15f, 1.1f});
  const Comparison c = compare(bar, kBarPlace, joints, {}, frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f}), 2);
  g.renderer->setGBufferPath(render::GBufferPath::Raster);
  if (!hasPass(c.gpu, "visibility")) {
    MESSAGE("this device has no compute G-buffer (64-bit atomics); the raster path drew it");
  }
  const size_t flips = differing(c.gpu, c.cpu);
  MESSAGE("compute G-buffer: posed vs CPU copy: " << flips << " pixels differ; from rest "
                                                  << differing(c.gpu, c.rest));
  CHECK(share(flips) <= kFlipShare);
  CHECK(share(differing(c.gpu, c.rest)) >= 0.02);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: without a pose a skin is drawn in its nodes' rest pose") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  scene::Scene s = stage(bar, kBarPlace, true);
  test::addBarSkin(s, kBarLength, 2);
  // The second joint's node is bent in the file itself.
  s.nodes[1].rotation = glm::angleAxis(0.7f, glm::vec3(0.0f, 0.0f, 1.0f));
  g.setScene(s);
  const render::FrameSettings f = frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f});
  const render::Frame rest = g.render(f);
  CHECK(hasPass(rest, "skin"));  // the first frame poses the regions
  g.setScene(stage(test::posedOnCpu(bar, test::barPose(kBarLength, {0.0f, 0.7f}), {}), kBarPlace, false));
  const render::Frame cpu = g.render(f);
  const size_t flips = differing(rest, cpu);
  MESSAGE("rest pose from the nodes: " << flips << " pixels differ from the CPU copy");
  CHECK(share(flips) <= kFlipShare);
  CHECK(g.context->validationMessages.load() == 0);
}

TEST_CASE("skinning: frames in flight each keep their own pose") {
  test::GpuSuite& g = sharedGpu();
  const scene::Mesh bar = test::makeBar(kBarLength, 0.25f, 33, 2);
  scene::Scene s = stage(bar, kBarPlace, true);
  test::addBarSkin(s, kBarLength, 2);
  g.setScene(s);
  render::FrameSettings f = frameOf({0.5f, 4.5f, 7.0f}, {0.5f, 3.2f, 0.0f});
  f.sun = g.lighting.sun;
  f.ambient = g.lighting.ambient;
  f.background = g.lighting.background;
  std::vector<render::FrameSettings> frames;
  for (float angle : {0.3f, -0.6f, 0.9f}) {
    f.pose = poseOf(2, test::barPose(kBarLength, {0.0f, angle}));
    frames.push_back(f);
  }
  std::vector<render::Frame> serial;
  for (const render::FrameSettings& each : frames) serial.push_back(g.renderer->render(g.scene, each));
  g.renderer->setFramesInFlight(3);
  std::vector<uint32_t> slots;
  for (const render::FrameSettings& each : frames) slots.push_back(g.renderer->beginFrame(g.scene, each));
  for (size_t i = 0; i < slots.size(); ++i) {
    const render::Frame inFlight = g.renderer->finishFrame(slots[i]);
    CHECK(std::ranges::equal(inFlight.pixels(), serial[i].pixels()));
  }
  g.renderer->setFramesInFlight(1);
  CHECK(share(differing(serial[0], serial[1])) >= 0.01);
  CHECK(g.context->validationMessages.load() == 0);
}
