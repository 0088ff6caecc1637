// Multi-target frames in the renderer (render/extra_targets.h, FrameSettings::alsoRead): one
// render whose further targets are read back after its own equals, bit for bit, the single frames
// of each target, whether the frame's own output is the 8-bit final picture or a raw view, whole
// or split into bounded submissions; validation layers silent throughout.
#include <doctest/doctest.h>

#include <bit>
#include <cstring>
#include <memory>
#include <optional>
#include <vector>

#include "gpu_test_support.h"
#include "render/extra_targets.h"
#include "scene/builtin_scene.h"

using namespace myriad;

namespace {

test::GpuSuite& sharedGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

render::FrameSettings base(const scene::Scene& s, render::Target target, bool raw) {
  render::FrameSettings f;
  f.width = 96;
  f.height = 64;
  f.camera = s.camera;
  f.target = target;
  f.raw = raw;
  return f;
}

std::span<const float> extraOf(const render::Frame& frame, render::Target target) {
  for (const render::Frame::TargetValues& v : frame.extras) {
    if (v.target == target) return v.data;
  }
  FAIL("no extra for ", render::targetName(target));
  return {};
}

bool sameBits(std::span<const float> a, std::span<const float> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Each of `multi`'s targets against the frame of that target alone.
void checkAgainstSingles(test::GpuSuite& gpu, const render::FrameSettings& multi,
                         const render::Frame& frame) {
  const render::FrameSettings alone = [&] {
    render::FrameSettings f = multi;
    f.alsoRead.clear();
    return f;
  }();
  const render::Frame own = gpu.render(alone);
  if (multi.raw) {
    CHECK(sameBits(frame.data, own.data));
  } else {
    CHECK(std::vector<uint8_t>(frame.pixels().begin(), frame.pixels().end()) == own.rgba);
  }
  bool labelsChecked = false;
  for (render::Target t : multi.alsoRead) {
    CAPTURE(render::targetName(t));
    render::FrameSettings single = alone;
    single.target = t;
    single.raw = true;
    const render::Frame expected = gpu.render(single);
    if (render::isLabel(t)) {
      // One readback holds the label pass's four uint32s for every id target.
      const std::span<const float> labels =
          render::isLabel(multi.target) ? std::span<const float>(frame.data) : frame.labels;
      CHECK(sameBits(labels, expected.data));
      labelsChecked = true;
    } else {
      CHECK(sameBits(extraOf(frame, t), expected.data));
    }
  }
  (void)labelsChecked;
}

}  // namespace

TEST_CASE("multi-target frames: every further target equals its single frame, final 8-bit or raw") {
  test::GpuSuite& gpu = sharedGpu();
  const scene::Scene s = scene::makeBuiltinScene(32);
  gpu.setScene(s);

  // The 8-bit final picture as the frame's own output; views and ids read back after it.
  render::FrameSettings withFinal = base(s, render::Target::Final, false);
  withFinal.alsoRead = {render::Target::Depth,      render::Target::Normal,
                        render::Target::Uv,         render::Target::Emissive,
                        render::Target::InstanceId, render::Target::SemanticId,
                        render::Target::LightCount};
  const render::Frame a = gpu.render(withFinal);
  CHECK(a.extras.size() == 5);
  CHECK(a.labels.size() == size_t(96) * 64 * 4);
  bool timed = false;
  for (const render::PassTiming& p : a.passes) timed = timed || p.name == "extra-targets";
  CHECK(timed);
  checkAgainstSingles(gpu, withFinal, a);

  // A raw view as the frame's own output.
  render::FrameSettings rawMain = base(s, render::Target::Depth, true);
  rawMain.alsoRead = {render::Target::Normal, render::Target::Position, render::Target::MaterialId,
                      render::Target::Albedo};
  const render::Frame b = gpu.render(rawMain);
  checkAgainstSingles(gpu, rawMain, b);

  // Labels alone: the frame's own readback holds them; no further region.
  render::FrameSettings labels = base(s, render::Target::InstanceId, true);
  labels.alsoRead = {render::Target::SemanticId, render::Target::MaterialId};
  CHECK(render::extraRegionsOf(labels).count == 0);
  const render::Frame c = gpu.render(labels);
  CHECK(c.extras.empty());
  checkAgainstSingles(gpu, labels, c);

  // What alsoRead may not hold.
  render::FrameSettings bad = base(s, render::Target::Depth, true);
  bad.alsoRead = {render::Target::Final};
  CHECK_THROWS_AS(gpu.render(bad), std::invalid_argument);
  bad.alsoRead = {render::Target::Normal, render::Target::Normal};
  CHECK_THROWS_AS(gpu.render(bad), std::invalid_argument);
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("multi-target frames: a split frame reads back the same further targets") {
  test::GpuSuite& gpu = sharedGpu();
  const scene::Scene s = scene::makeBuiltinScene(3000);
  gpu.setScene(s);
  render::Renderer& r = *gpu.renderer;
  render::FrameSettings multi = base(s, render::Target::Final, false);
  multi.technique = render::Technique::Volumes;
  multi.sun = gpu.lighting.sun;
  multi.ambient = gpu.lighting.ambient;
  multi.background = gpu.lighting.background;
  multi.extraSuns = gpu.lighting.extraSuns;
  multi.alsoRead = {render::Target::Depth, render::Target::Normal, render::Target::InstanceId,
                    render::Target::LightCount};
  const render::Frame whole = gpu.render(multi);
  r.setSliceMilliseconds(5.0);
  REQUIRE(r.shouldSplit(gpu.scene, multi));
  std::unique_ptr<render::Renderer::SplitFrame> split = r.beginSplit(gpu.scene, multi);
  std::optional<render::Frame> done;
  while (!(done = r.continueSplit(*split))) {
  }
  split.reset();
  r.setSliceMilliseconds(render::Renderer::kSliceMilliseconds);
  MESSAGE("3,000 lights, 5 targets, split into ", done->submissions, " submissions");
  CHECK(done->submissions > 1);
  CHECK(std::vector<uint8_t>(done->pixels().begin(), done->pixels().end()) ==
        std::vector<uint8_t>(whole.pixels().begin(), whole.pixels().end()));
  for (render::Target t : {render::Target::Depth, render::Target::Normal, render::Target::LightCount}) {
    CAPTURE(render::targetName(t));
    CHECK(sameBits(extraOf(*done, t), extraOf(whole, t)));
  }
  CHECK(sameBits(done->labels, whole.labels));
  CHECK(gpu.context->validationMessages.load() == 0);
}
