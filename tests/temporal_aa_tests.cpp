// Temporal anti-aliasing of a stream's frames (render/temporal.h: antialias=taa with a
// FrameSettings::historyKey): one jittered frame per stream frame, resolved on the GPU against
// the key's history. With validation on, on the scene and measure of antialias_modes_tests.cpp:
// two dark boxes on a bright floor from straight above at 160x120, the edge error against the
// `none` image at 4x the size box-downsampled in linear light (edge pixels: where the reference
// differs from a 4-neighbour by more than 16/255; the error: the mean absolute difference there,
// in sRGB codes). Issue 36: a still camera converges (>= 50% less edge error than none after 8+
// frames), a moving one does not ghost, a disocclusion recovers within a few frames, data views
// are none's byte for byte.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "antialias_measure.h"
#include "gpu_test_support.h"
#include "render/renderer.h"
#include "render/sub_frames.h"
#include "render/temporal.h"
#include "scene/primitives.h"

using namespace myriad;

namespace {

using namespace test::aa;

test::GpuSuite& sharedGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

// `x`: the camera's offset along x (it looks straight down from 6 m).
render::FrameSettings frameOf(render::Antialias antialias, uint64_t key = 0, float x = 0.0f,
                              uint32_t scale = 1) {
  render::FrameSettings f;
  f.width = kWidth * scale;
  f.height = kHeight * scale;
  f.camera.eye = glm::vec3(x, 6.0f, 0.0f);
  f.camera.target = glm::vec3(x, 0.0f, 0.0f);
  f.camera.up = glm::vec3(0.0f, 0.0f, -1.0f);
  f.camera.fovYDegrees = 60.0f;
  f.camera.nearPlane = 0.1f;
  f.camera.farPlane = 50.0f;
  f.technique = render::Technique::Clustered;
  f.markers = false;
  f.antialias = antialias;
  f.historyKey = key;
  return f;
}

// The largest RGB difference between two frames over the pixels `where` holds (all: empty).
int largestDifference(const render::Frame& a, const render::Frame& b,
                      const std::vector<bool>& where = {}) {
  const auto pa = a.pixels(), pb = b.pixels();
  REQUIRE(pa.size() == pb.size());
  int worst = 0;
  for (size_t i = 0; i < pa.size() / 4; ++i) {
    if (!where.empty() && !where[i]) continue;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(pa[i * 4 + c]) - int(pb[i * 4 + c])));
  }
  return worst;
}

std::vector<bool> invert(std::vector<bool> v) {
  v.flip();
  return v;
}


bool hasPass(const render::Frame& f, const char* name) {
  return std::any_of(f.passes.begin(), f.passes.end(), [&](const render::PassTiming& p) { return p.name == name; });
}

}  // namespace

TEST_CASE("temporal aa: a still stream converges to the supersampled reference") {
  test::GpuSuite& gpu = sharedGpu();
  gpu.setScene(boxesScene());
  render::Renderer& r = *gpu.renderer;
  r.releaseFrameMemory();
  const std::vector<float> reference =
      downsampled(gpu.render(frameOf(render::Antialias::None, 0, 0.0f, kReferenceScale)));
  const std::vector<bool> edges = edgePixels(reference);
  REQUIRE(std::count(edges.begin(), edges.end(), true) > 300);
  const render::Frame none = gpu.render(frameOf(render::Antialias::None));
  const double eNone = edgeError(none, reference, edges);
  CHECK(eNone > 10.0);

  constexpr uint64_t kKey = 101;
  std::vector<double> errors;
  render::Frame last;
  for (uint32_t i = 0; i < 12; ++i) {
    last = gpu.render(frameOf(render::Antialias::Taa, kKey));
    errors.push_back(edgeError(last, reference, edges));
    CHECK(last.submissions == 1);  // one frame, not 8 sub-frames
    CHECK(hasPass(last, "taa"));
    CHECK_FALSE(hasPass(last, "resolve-taa"));
  }
  std::string text;
  for (double e : errors) text += " " + std::to_string(e).substr(0, 5);
  MESSAGE("stream taa, still camera: edge error per frame" << text << " (none " << eNone
          << "; frame 12: " << 100.0 * (1.0 - errors.back() / eNone) << "% less)");
  CHECK(errors[0] > 0.6 * eNone);  // one jittered frame is not anti-aliased yet
  CHECK(errors[7] <= 0.5 * eNone);  // 8 offsets
  CHECK(errors[11] <= 0.5 * eNone);
  // Away from edges the picture is none's (within rounding).
  const int away = largestDifference(last, none, invert(nearEdges(edges, 2)));
  MESSAGE("largest difference from none away from edges: " << away << "/255");
  CHECK(away <= 2);

  // The history: one key, 28 bytes a pixel; another key renders its own sequence (the same
  // bytes for the same frames), and a released key starts again.
  CHECK(r.historyCount() == 1);
  CHECK(r.historyBytes() >= uint64_t(kWidth) * kHeight * 28);
  render::Frame other;
  for (uint32_t i = 0; i < 3; ++i) other = gpu.render(frameOf(render::Antialias::Taa, kKey + 1));
  CHECK(r.historyCount() == 2);
  r.releaseHistory(kKey);
  r.releaseHistory(kKey + 1);
  CHECK(r.historyCount() == 0);
  CHECK(r.historyBytes() == 0);
  render::Frame again;
  for (uint32_t i = 0; i < 3; ++i) again = gpu.render(frameOf(render::Antialias::Taa, kKey));
  CHECK(bytesOf(again) == bytesOf(other));
  r.releaseHistory(kKey);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("temporal aa: a moving camera does not ghost; a disocclusion recovers") {
  test::GpuSuite& gpu = sharedGpu();
  gpu.setScene(boxesScene());
  render::Renderer& r = *gpu.renderer;
  constexpr uint64_t kKey = 202;
  for (uint32_t i = 0; i < 10; ++i) gpu.render(frameOf(render::Antialias::Taa, kKey));

  // A pan of about half a pixel a frame (0.03 m; a pixel is 0.058 m on the floor, 0.048 m on
  // the boxes' tops), 8 frames: the edges stay anti-aliased, nothing trails behind them.
  float x = 0.0f;
  render::Frame moving;
  for (uint32_t i = 0; i < 8; ++i) {
    x += 0.03f;
    moving = gpu.render(frameOf(render::Antialias::Taa, kKey, x));
  }
  {
    const std::vector<float> reference =
        downsampled(gpu.render(frameOf(render::Antialias::None, 0, x, kReferenceScale)));
    const std::vector<bool> edges = edgePixels(reference);
    const render::Frame none = gpu.render(frameOf(render::Antialias::None, 0, x));
    const double eNone = edgeError(none, reference, edges);
    const double eTaa = edgeError(moving, reference, edges);
    const int away = largestDifference(moving, none, invert(nearEdges(edges, 2)));
    MESSAGE("panning 0.5 px a frame, after 8 frames: edge error " << eTaa << " (none " << eNone
            << ", " << 100.0 * (1.0 - eTaa / eNone) << "% less); away from edges at most " << away
            << "/255 from none");
    // The history is resampled at every frame (Catmull-Rom): the edges soften a little while the
    // camera moves (measured 11.6 against 16.3), never worse than none's, and nothing trails
    // behind them.
    CHECK(eTaa <= eNone);
    CHECK(away <= 4);
  }

  // A jump of 1 m (17 pixels): the old picture must not stay behind. One frame later every pixel
  // away from the edges is none's, and the edges are no worse than none's.
  x += 1.0f;
  {
    const render::Frame jumped = gpu.render(frameOf(render::Antialias::Taa, kKey, x));
    const std::vector<float> reference =
        downsampled(gpu.render(frameOf(render::Antialias::None, 0, x, kReferenceScale)));
    const std::vector<bool> edges = edgePixels(reference);
    const render::Frame none = gpu.render(frameOf(render::Antialias::None, 0, x));
    const double eNone = edgeError(none, reference, edges);
    const double eTaa = edgeError(jumped, reference, edges);
    const int away = largestDifference(jumped, none, invert(nearEdges(edges, 2)));
    double mean = 0.0;
    {
      const std::vector<bool> far = invert(nearEdges(edges, 2));
      const auto a = jumped.pixels(), b = none.pixels();
      size_t n = 0;
      for (size_t k = 0; k < far.size(); ++k) {
        if (!far[k]) continue;
        for (int c = 0; c < 3; ++c) mean += std::abs(int(a[k * 4 + c]) - int(b[k * 4 + c]));
        n += 3;
      }
      mean /= double(n);
    }
    MESSAGE("a 1 m jump, the frame after: edge error " << eTaa << " (none " << eNone
            << "); away from edges at most " << away << "/255 from none, " << mean << " on average");
    // A ghost of the old picture (the boxes 17 pixels off: dark on the bright floor) would differ
    // by 150 and more; what differs is the boxes' unlit sides, dark on dark.
    CHECK(eTaa <= 1.1 * eNone);
    CHECK(away <= 16);
    CHECK(mean <= 0.5);
  }

  // A disocclusion: the dark box moves 1.5 m along x (the scene replaced, the stream's history
  // kept). The floor it uncovers, and the floor it now covers, must be right at once: the
  // history's depth there is another surface's.
  for (uint32_t i = 0; i < 10; ++i) gpu.render(frameOf(render::Antialias::Taa, kKey, x));
  const render::Frame before = gpu.render(frameOf(render::Antialias::None, 0, x));
  gpu.setScene(boxesScene(1.5f));
  const render::Frame after = gpu.render(frameOf(render::Antialias::None, 0, x));
  // The pixels that changed, less 2 pixels around every edge of either picture.
  std::vector<bool> changed(size_t(kWidth) * kHeight, false);
  {
    std::vector<bool> anyEdge(changed.size(), false);
    const auto pb = before.pixels(), pa = after.pixels();
    for (size_t i = 0; i < changed.size(); ++i) changed[i] = std::abs(int(pb[i * 4]) - int(pa[i * 4])) > 40;
    auto edgesOf = [&](const render::Frame& f) {
      std::vector<float> codes(changed.size() * 3);
      for (size_t i = 0; i < changed.size(); ++i) {
        for (int c = 0; c < 3; ++c) codes[i * 3 + c] = f.pixels()[i * 4 + c];
      }
      return nearEdges(edgePixels(codes), 2);
    };
    const std::vector<bool> e1 = edgesOf(before), e2 = edgesOf(after);
    for (size_t i = 0; i < changed.size(); ++i) changed[i] = changed[i] && !e1[i] && !e2[i];
  }
  const size_t changedCount = size_t(std::count(changed.begin(), changed.end(), true));
  REQUIRE(changedCount > 200);
  std::vector<int> worst;
  for (uint32_t i = 0; i < 4; ++i) {
    worst.push_back(largestDifference(gpu.render(frameOf(render::Antialias::Taa, kKey, x)), after, changed));
  }
  MESSAGE("disocclusion (" << changedCount << " pixels uncovered or covered): largest difference from none"
          << " in frames 1-4 after the move: " << worst[0] << ", " << worst[1] << ", " << worst[2]
          << ", " << worst[3] << " /255");
  CHECK(worst[0] <= 4);
  CHECK(worst[1] <= 4);
  CHECK(worst[3] <= 4);
  r.releaseHistory(kKey);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("temporal aa: data views are none's byte for byte; histories are bounded and freed") {
  test::GpuSuite& gpu = sharedGpu();
  scene::Scene scene = boxesScene();
  scene.lights = {{glm::vec3(1.8f, 1.2f, 0.5f), 2.0f, glm::vec3(1.0f, 0.6f, 0.2f), 4.0f, 1.0f}};
  gpu.setScene(scene);
  render::Renderer& r = *gpu.renderer;
  r.releaseFrameMemory();
  constexpr uint64_t kKey = 303;
  size_t compared = 0;
  for (render::Target target : {render::Target::Final, render::Target::Depth, render::Target::Normal,
                                render::Target::Albedo, render::Target::InstanceId, render::Target::Motion,
                                render::Target::LightVolumes}) {
    for (bool raw : {false, true}) {
      if (target == render::Target::Final && !raw) continue;
      if (render::isLabel(target) && !raw) continue;
      CAPTURE(render::targetName(target));
      CAPTURE(raw);
      render::FrameSettings f = frameOf(render::Antialias::None);
      f.target = target;
      f.raw = raw;
      const render::Frame off = gpu.render(f);
      size_t nonFinite = 0;
      for (float v : off.data) nonFinite += std::isfinite(v) ? 0 : 1;
      CHECK(nonFinite == 0);
      f.antialias = render::Antialias::Taa;
      f.historyKey = kKey;
      for (int i = 0; i < 2; ++i) {  // twice: no history carries into a data view either
        const render::Frame on = gpu.render(f);
        CHECK(on.rgba == off.rgba);
        CHECK(sameBits(on.data, off.data));
        CHECK(on.submissions == 1);
        CHECK_FALSE(hasPass(on, "taa"));
        ++compared;
      }
    }
  }
  CHECK(compared == 2 * 12);
  CHECK(r.historyCount() == 0);  // none of them made a history

  // final + data views with a key: not a stream frame, the still's sub-frames (the views from
  // an unjittered render, none's byte for byte).
  render::FrameSettings multi = frameOf(render::Antialias::None);
  multi.alsoRead = {render::Target::Depth, render::Target::Normal, render::Target::InstanceId};
  const render::Frame plain = gpu.render(multi);
  multi.antialias = render::Antialias::Taa;
  multi.historyKey = kKey;
  const render::Frame with = gpu.render(multi);
  CHECK(hasPass(with, "resolve-taa"));
  CHECK_FALSE(hasPass(with, "taa"));
  for (render::Target t : {render::Target::Depth, render::Target::Normal}) {
    CAPTURE(render::targetName(t));
    CHECK(sameBits(extraOf(with, t), extraOf(plain, t)));
  }
  CHECK(sameBits(with.labels, plain.labels));
  CHECK(r.historyCount() == 0);
  {
    // A stream's first frame has no history: the jittered picture itself (the first offset).
    render::FrameSettings jittered = frameOf(render::Antialias::None);
    jittered.jitter = render::taaJitter(0);
    const render::Frame expected = gpu.render(jittered);
    const render::Frame first = gpu.render(frameOf(render::Antialias::Taa, kKey));
    CHECK(bytesOf(first) == bytesOf(expected));
    r.releaseHistory(kKey);
  }

  // Bounded: kMaxHistories keys at most (the least recently used goes); another size makes the
  // key's history again; the idle trim (releaseFrameMemory) frees them all.
  render::FrameSettings small = frameOf(render::Antialias::Taa);
  small.width = 32;
  small.height = 24;
  for (uint64_t key = 1; key <= render::kMaxHistories + 3; ++key) {
    small.historyKey = 1000 + key;
    gpu.render(small);
    CHECK(r.historyCount() == std::min<size_t>(key, render::kMaxHistories));
  }
  const uint64_t bytes = r.historyBytes();
  small.width = 48;
  gpu.render(small);  // the last key, another size
  CHECK(r.historyCount() == render::kMaxHistories);
  CHECK(r.historyBytes() > bytes);
  const uint64_t memory = r.gpuMemoryBytes();
  r.releaseFrameMemory();
  CHECK(r.historyCount() == 0);
  CHECK(r.gpuMemoryBytes() < memory);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("temporal aa: a split stream frame equals the whole one") {
  test::GpuSuite& gpu = sharedGpu();
  gpu.setScene(boxesScene());
  render::Renderer& r = *gpu.renderer;
  render::FrameSettings f = frameOf(render::Antialias::Taa, 404);
  f.sun = gpu.lighting.sun;
  f.ambient = gpu.lighting.ambient;
  f.background = gpu.lighting.background;
  render::Frame whole;
  for (int i = 0; i < 3; ++i) whole = r.render(gpu.scene, f);
  f.historyKey = 405;
  r.render(gpu.scene, f);
  r.render(gpu.scene, f);
  r.setSliceMilliseconds(0.01);
  REQUIRE(r.shouldSplit(gpu.scene, f));
  std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(gpu.scene, f);
  std::optional<render::Frame> done;
  while (!(done = r.continueSplit(*split))) {
  }
  split.reset();
  r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
  CHECK(done->submissions > 2);
  CHECK(bytesOf(*done) == bytesOf(whole));
  r.releaseHistory(404);
  r.releaseHistory(405);
  CHECK(gpu.context->validationMessages.load() == 0);
}

// The resolve's cost at 1280x720 against `none` (not run by CTest: lavapipe takes seconds a
// frame there). `myriad_gpu_tests --test-case="temporal aa: cost*" --no-skip`.
TEST_CASE("temporal aa: cost at 1280x720" * doctest::skip()) {
  test::GpuSuite& gpu = sharedGpu();
  gpu.setScene(boxesScene());
  auto at720 = [](render::Antialias mode, uint64_t key) {
    render::FrameSettings f = frameOf(mode, key);
    f.width = 1280;
    f.height = 720;
    return f;
  };
  auto passMs = [](const render::Frame& f, const char* name) {
    for (const render::PassTiming& p : f.passes) {
      if (p.name == name) return p.milliseconds;
    }
    return 0.0;
  };
  for (int i = 0; i < 2; ++i) gpu.render(at720(render::Antialias::None, 0));  // warm
  // Interleaved, 9 of each; the machine is shared: the least and the median of each.
  std::vector<double> none, taa, resolve, fin;
  for (int i = 0; i < 9; ++i) {
    const render::Frame a = gpu.render(at720(render::Antialias::None, 0));
    const render::Frame b = gpu.render(at720(render::Antialias::Taa, 505));
    none.push_back(a.times.gpuMs);
    taa.push_back(b.times.gpuMs);
    resolve.push_back(passMs(b, "taa"));
    fin.push_back(passMs(a, "final"));
  }
  auto text = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return std::to_string(v.front()).substr(0, 6) + " least, " + std::to_string(v[v.size() / 2]).substr(0, 6) + " median";
  };
  MESSAGE("1280x720 GPU ms: none " << text(none) << "; stream taa " << text(taa) << "; its taa pass "
          << text(resolve) << "; none's final pass " << text(fin));
  gpu.renderer->releaseHistory(505);
  CHECK(gpu.context->validationMessages.load() == 0);
}

