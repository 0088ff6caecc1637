// Frames too long for one submission (Renderer::SplitFrame, renderer.h): the frame's steps
// recorded in ranges of their units, a bounded submission at a time, each range sized from what
// the ones before it cost.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "gpu/vk_check.h"
#include "render/renderer_state.h"
#include "render/sub_frames.h"

namespace myriad::render {

namespace {

// Split frames (Renderer::SplitFrame). A frame of a scene not measured yet (no frame of it with
// that technique and about as many lights) splits when it has more lights than this, more pixels
// than this, or more pixels x lights: on lavapipe (2 cores) a 1920x1080 frame of the built-in
// scene's 256 lights takes about 0.5 s, 4096x4096 of 8 lights 3 s, 320x180 of a million
// clustered lights a minute. Splitting a frame that did not need it costs a few submissions.
constexpr uint32_t kUnmeasuredSplitLights = 65536;
constexpr double kUnmeasuredSplitPixels = 2560.0 * 1440.0;
constexpr double kUnmeasuredSplitPixelLights = 1920.0 * 1080.0 * 1024.0;
// A measured frame's cost is taken as valid for frames of its scene and technique with between
// half and twice its lights (cost ~ pixels x lights reaching them; fewer lights are not assumed
// cheaper, more are scaled up).
constexpr double kCostLightsRange = 2.0;
// The first range of a step with many units, before any of them was measured: this fraction of
// its units (at least one). Small: a light volume at 1920x1080 took 4.4 ms on lavapipe, and 1/1024
// of a million of them held the queue for 4.3 s; 15 of them 66 ms, and the next range is sized
// from that.
constexpr uint32_t kFirstRangeShare = 65536;
// A range weighs at most this many times the step's previous one, for units alike and not
// (LightingTechnique::Step::unitsAlike): a few units measured cheap do not let the next range
// take the rest of the step at once. Tiles differ most: a 16x16 tile of sky took 14 ms on
// lavapipe beside a million clustered lights, one of the floor below it 160-900 ms.
constexpr double kRangeGrowthAlike = 8.0;
constexpr double kRangeGrowthUnlike = 2.0;
// A step's ranges project the rest of it (for the frame budget) once one took this share of a
// slice: shorter ones are mostly the part's own overhead (a submission, a barrier, a wait).
constexpr double kWellMeasured = 0.25;
// How far a step's cost estimate falls after a cheaper range (runSplitPart), for units alike
// (the first ranges' part overhead fades in a few parts) and not (a costly tile keeps the
// estimate up for several parts).
constexpr double kEstimateDecayAlike = 0.5;
constexpr double kEstimateDecayUnlike = 0.9;
// A split frame projected past the frame budget stops once it has taken this share of it.
constexpr double kProjectAfterShare = 0.1;

// Adds `results` (one submission's passes) to `passes`, summing passes of the same name.
void addPasses(std::vector<PassTiming>& passes,
               const std::vector<std::pair<std::string, double>>& results) {
  // (No structured binding: clang before 16, which builds the fuzz preset, cannot capture one.)
  for (const auto& result : results) {
    const std::string& name = result.first;
    auto it = std::find_if(passes.begin(), passes.end(),
                           [&](const PassTiming& p) { return p.name == name; });
    if (it == passes.end()) {
      passes.push_back({name, result.second});
    } else {
      it->milliseconds += result.second;
    }
  }
}

}  // namespace

double Renderer::estimateMilliseconds(SceneId id, const FrameSettings& settings) const {
  const State& s = *state_;
  const SceneBuffers& scene = s.scene(id);
  const auto it = s.costs.find(id);
  if (it == s.costs.end() || it->second.technique != settings.technique) return -1.0;
  const State::FrameCost& cost = it->second;
  const double lights = std::max(1.0, double(scene.lightCount));
  const double measuredLights = std::max(1.0, double(cost.lights));
  if (lights > measuredLights * kCostLightsRange || lights * kCostLightsRange < measuredLights) {
    return -1.0;
  }
  // Linear in the pixels; more lights than measured scale it up, fewer are not assumed cheaper.
  return cost.ms * pixelsOf(settings) / std::max(1.0, cost.pixels) *
         std::max(1.0, lights / measuredLights);
}

bool Renderer::shouldSplit(SceneId id, const FrameSettings& settings) const {
  const State& s = *state_;
  if (settings.resolvedFromSubFrames()) {
    // A taa or ssaa frame renders whole when its sub-frames together would (beginFrame renders
    // them one after another, holding the queue meanwhile): their estimates summed, and those
    // not measured yet judged as one frame of their pixels together.
    double total = 0.0, unmeasuredPixels = 0.0;
    for (const FrameSettings& sub : SubFrameResolve(settings, maxDimension()).frames()) {
      const double estimate = estimateMilliseconds(id, sub);
      if (estimate < 0.0) {
        unmeasuredPixels += pixelsOf(sub);
      } else {
        total += estimate;
      }
    }
    const double lights = double(s.scene(id).lightCount);
    const bool unmeasuredSplits =
        unmeasuredPixels > 0.0 &&
        (lights > kUnmeasuredSplitLights || unmeasuredPixels > kUnmeasuredSplitPixels ||
         unmeasuredPixels * lights > kUnmeasuredSplitPixelLights);
    return unmeasuredSplits || total > s.wholeFrameMs;
  }
  const double estimate = estimateMilliseconds(id, settings);
  if (estimate >= 0.0) return estimate > s.wholeFrameMs;
  const double lights = double(s.scene(id).lightCount);
  const double pixels = pixelsOf(settings);
  return lights > kUnmeasuredSplitLights || pixels > kUnmeasuredSplitPixels ||
         pixels * lights > kUnmeasuredSplitPixelLights;
}

bool Renderer::splitBusy() const { return state_->splitBusy; }

void Renderer::setSliceMilliseconds(double milliseconds) {
  state_->sliceMs = milliseconds;
  state_->wholeFrameMs = 2.0 * milliseconds;
}

void Renderer::setFrameBudgetMilliseconds(double milliseconds) {
  state_->frameBudgetMs = std::max(0.0, milliseconds);
}

Renderer::SplitFrame::~SplitFrame() { renderer_.state_->splitBusy = false; }

double Renderer::SplitFrame::Step::weightOf(uint32_t first, uint32_t count) const {
  if (weights.empty()) return double(count);
  double sum = 0.0;
  const size_t end = std::min<size_t>(weights.size(), size_t(first) + count);
  for (size_t i = first; i < end; ++i) sum += weights[i];
  return sum;
}

double Renderer::SplitFrame::projectedMilliseconds() const {
  double rest = 0.0;
  for (size_t i = step_; i < steps_.size(); ++i) {
    const Step& st = steps_[i];
    const uint32_t first = i == step_ ? nextUnit_ : 0;
    // Not measured (or only in ranges too short to tell): not counted.
    if (!st.measuredWell || first >= st.units) continue;
    rest += st.msPerWeight * st.weightOf(first, st.units - first);
  }
  return elapsedMs_ + rest;
}

std::unique_ptr<Renderer::SplitFrame> Renderer::beginSplit(SceneId id,
                                                           const FrameSettings& asked) {
  State& s = *state_;
  if (s.splitBusy) throw std::logic_error("another split frame is unfinished");
  checkSize(asked, maxDimension());
  // A taa or ssaa frame: its sub-frames one after another (render/sub_frames.h).
  std::shared_ptr<SubFrameResolve> resolve;
  if (asked.resolvedFromSubFrames()) resolve = std::make_shared<SubFrameResolve>(asked, maxDimension());
  const FrameSettings& first = resolve ? resolve->frames().front() : asked;
  s.quiesce();  // its parts are waited for one by one; frames in flight go first
  s.scene(id);  // throws for an unknown id
  checkSize(first, maxDimension());
  checkLabels(first);
  s.splitTechnique(first.technique);  // throws for an unknown technique
  s.environmentFor(id, first);        // throws for hdr without an image
  // A stream's taa frame: jittered, its history's next frame (render/temporal.h).
  const FrameSettings settings = s.temporal->plan(first, s.split.temporal);
  std::unique_ptr<SplitFrame> frame(new SplitFrame(*this, id, settings));
  frame->resolve_ = std::move(resolve);
  s.splitBusy = true;  // until `frame` is destroyed
  s.startSplit(*frame);
  return frame;
}

void Renderer::State::startSplit(SplitFrame& splitFrame) {
  State& s = *this;
  SplitFrame* f = &splitFrame;
  const FrameSettings& settings = f->settings_;
  SceneBuffers& scene = s.scene(f->scene_);
  LightingTechnique& technique = s.splitTechnique(settings.technique);
  SceneEnvironment* environment = s.environmentFor(f->scene_, settings);
  f->steps_.clear();
  f->step_ = 0;
  f->nextUnit_ = 0;
  f->listsGrew_ = false;
  f->passes_.clear();
  s.prepareFrame(s.split, scene, environment, settings, technique);
  // The steps, recorded in order: everything before the lighting (one unit), the technique's
  // steps, the passes after it. Scene, environment and technique stay as they are until the
  // frame ends (the render thread runs no edit of its scene meanwhile).
  State* state = &s;
  SplitFrame::Step before;
  before.units = 1;
  before.record = [state, &scene, environment, f](VkCommandBuffer cmd, uint32_t, uint32_t) {
    state->recordBeforeLighting(cmd, state->split, scene, environment, f->settings_);
  };
  f->steps_.push_back(std::move(before));
  f->firstLightingStep_ = f->steps_.size();
  const bool computeGBuffer = s.computeGBufferFor(scene, settings);
  const bool animate = settings.animate && technique.animatesLights();
  const bool traced = StochasticShadows::wanted(settings);
  auto lightingPass = [state, &scene, computeGBuffer, animate, traced](VkCommandBuffer cmd) {
    LightingPass pass{cmd, *state->split.timer, *state->split.targets, scene,
                      state->split.shadingFeatures, animate, computeGBuffer};
    pass.split = true;
    if (traced) pass.stochastic = &state->stochastic;
    return pass;
  };
  const std::vector<LightingTechnique::Step> lighting = technique.steps(lightingPass(VK_NULL_HANDLE));
  for (uint32_t i = 0; i < lighting.size(); ++i) {
    SplitFrame::Step step;
    step.units = step.declaredUnits = lighting[i].units;
    step.lightingStep = int(i);
    step.listsBuilt = technique.listsBuiltAfter(i);
    step.unitsAlike = lighting[i].unitsAlike;
    const char* name = lighting[i].name;
    step.record = [state, &technique, lightingPass, name, i](VkCommandBuffer cmd, uint32_t first,
                                                             uint32_t count) {
      const LightingPass pass = lightingPass(cmd);
      pass.timer.beginPass(cmd, name);
      technique.recordStep(pass, i, first, count);
    };
    f->steps_.push_back(std::move(step));
  }
  f->images_ = State::afterLightingStates(technique.lightingLayout(), settings);
  for (const State::AfterStep& after : s.afterSteps) {
    SplitFrame::Step step;
    step.units = s.afterUnits(after, s.split, scene, settings);
    step.record = [state, &scene, &technique, f, &after](VkCommandBuffer cmd, uint32_t first,
                                                         uint32_t count) {
      state->recordAfterStep(cmd, state->split, scene, f->settings_, technique, f->images_, after,
                             first, count);
    };
    f->steps_.push_back(std::move(step));
  }
  // The first submission: everything before the lighting.
  s.runSplitPart(*f);
}

void Renderer::State::runSplitPart(SplitFrame& frame) {
  using Step = SplitFrame::Step;
  const auto partStart = std::chrono::steady_clock::now();
  quiesce();
  // The slot's sets, uniforms and targets are as beginSplit left them: whole frames use their own.
  VkCommandBuffer cmd = beginFrameCommands(split);
  struct Range {
    Step* step;
    double weight;
    double plannedMs;  // 0: not measured yet
  };
  std::vector<Range> ranges;
  double plannedMs = 0.0;
  bool end = false;
  while (!end && frame.step_ < frame.steps_.size()) {
    Step& st = frame.steps_[frame.step_];
    if (frame.nextUnit_ >= st.units) {
      ++frame.step_;
      frame.nextUnit_ = 0;
      continue;
    }
    if (!st.weighed) {
      // The technique's weights read what the steps before this one made: they must have run.
      if (!ranges.empty() && st.units > 1) break;
      if (st.lightingStep >= 0 && st.units > 1) {
        const LightingTechnique& technique = splitTechnique(frame.settings_.technique);
        st.units = technique.unitsWithWork(uint32_t(st.lightingStep), st.units);
        st.weights = technique.unitWeights(uint32_t(st.lightingStep), split.targets->extent);
        if (st.weights.size() != st.units) st.weights.clear();
      }
      st.weighed = true;
      if (frame.nextUnit_ >= st.units) continue;  // nothing to do after all
    }
    const uint32_t remaining = st.units - frame.nextUnit_;
    uint32_t count = 0;
    if (st.msPerWeight > 0.0) {
      // As many units as fit in what is left of the slice, weighing at most kRangeGrowth times
      // the last range.
      const double room = sliceMs - plannedMs;
      const double most = std::max(st.lastRangeWeight, 1.0) *
                          (st.unitsAlike ? kRangeGrowthAlike : kRangeGrowthUnlike);
      if (st.weights.empty()) {
        count = uint32_t(std::clamp(std::floor(std::min(room / st.msPerWeight, most)), 0.0,
                                    double(remaining)));
      } else {
        double sum = 0.0;
        while (count < remaining) {
          const double w = st.weights[frame.nextUnit_ + count];
          if ((sum + w) * st.msPerWeight > room || sum + w > most) break;
          sum += w;
          ++count;
        }
      }
      if (count == 0) {
        if (!ranges.empty()) break;
        count = 1;  // one unit over the slice: it cannot be cut finer
      }
    } else {
      // Not measured yet: alone in its part (a pass of unknown cost, or a first range small
      // enough to measure: a kFirstRangeShare of the step's weight).
      if (!ranges.empty()) break;
      if (st.weights.empty()) {
        count = std::min(remaining, std::max(1u, st.units / kFirstRangeShare));
      } else {
        const double share = st.weightOf(frame.nextUnit_, remaining) / kFirstRangeShare;
        double sum = 0.0;
        while (count < remaining && (count == 0 || sum < share)) {
          sum += st.weights[frame.nextUnit_ + count];
          ++count;
        }
      }
    }
    st.record(cmd, frame.nextUnit_, count);
    const double weight = st.weightOf(frame.nextUnit_, count);
    ranges.push_back({&st, weight, st.msPerWeight * weight});
    plannedMs += st.msPerWeight * weight;
    st.lastRange = count;
    st.lastRangeWeight = weight;
    frame.nextUnit_ += count;
    // Measured alone; and a step continues in the next part (its next range sized from this one).
    if (st.msPerWeight <= 0.0 || frame.nextUnit_ < st.units) end = true;
    if (frame.nextUnit_ >= st.units) {
      // After the lists are built the host reads their counters before anything shades.
      if (st.listsBuilt) end = true;
      ++frame.step_;
      frame.nextUnit_ = 0;
    }
  }
  split.timer->end(cmd);
  gpu::submitAndWait(context, split.recorder);
  const double ms = Milliseconds(std::chrono::steady_clock::now() - partStart).count();
  frame.elapsedMs_ += ms;
  ++frame.submissions_;
  addPasses(frame.passes_, split.timer->results());

  // What each range cost: the part's time shared by the ranges' estimates (those not measured
  // yet share what the others did not take). An estimate rises to a costlier measurement at
  // once and falls by half a part at most, or a tenth where units differ (tiles of sky and of
  // long lists: a range sized from the cheapest ones would hold the queue for many slices).
  double known = 0.0;
  size_t unknown = 0;
  for (const Range& r : ranges) {
    if (r.plannedMs > 0.0) {
      known += r.plannedMs;
    } else {
      ++unknown;
    }
  }
  const double scale = known > 0.0 && unknown == 0 ? ms / known : 1.0;
  const double leftover = unknown > 0 ? std::max(ms - known, 0.0) / double(unknown) : 0.0;
  for (const Range& r : ranges) {
    const double weight = std::max(r.weight, 1e-6);
    const double measured =
        r.plannedMs > 0.0 ? r.step->msPerWeight * scale : std::max(leftover, 0.001) / weight;
    r.step->msPerWeight = r.step->msPerWeight <= 0.0
                              ? measured
                              : std::max(measured, (r.step->unitsAlike ? kEstimateDecayAlike
                                                                       : kEstimateDecayUnlike) *
                                                       r.step->msPerWeight);
    r.step->measuredWell = r.step->measuredWell || measured * weight >= kWellMeasured * sliceMs;
  }

  // The lists are complete: when they overflowed and may grow, the lighting starts again with
  // larger ones (a frame with lights missing is never the answer while memory allows).
  const bool listsDone = !ranges.empty() && ranges.back().step->listsBuilt &&
                         frame.nextUnit_ == 0;
  if (listsDone) {
    LightingTechnique& technique = splitTechnique(frame.settings_.technique);
    if (const gpu::Buffer* counters = technique.counters()) {
      CullingReport report;
      technique.report(report, counters->mapped);
      if (technique.growLists(report)) {
        SceneBuffers& scene = this->scene(frame.scene_);
        const VkExtent2D extent = split.targets->extent;
        try {
          technique.prepare(extent, scene.lightCount);
        } catch (const gpu::VulkanError&) {
          technique.growthFailed();  // out of memory for them: the lists of before, once more
          technique.prepare(extent, scene.lightCount);
        }
        // The lists' capacity is in the uniforms.
        const std::optional<SunShadowFit> sun = sunShadowFor(scene, frame.settings_);
        writeUniforms(split, frame.settings_, scene, technique, sun ? &*sun : nullptr,
                      split.lightShadows);
        frame.listsGrew_ = true;
        frame.step_ = frame.firstLightingStep_;
        frame.nextUnit_ = 0;
        for (size_t i = frame.firstLightingStep_; i < frame.steps_.size(); ++i) {
          frame.steps_[i].weighed = false;
          frame.steps_[i].weights.clear();
          if (frame.steps_[i].lightingStep >= 0) frame.steps_[i].units = frame.steps_[i].declaredUnits;
        }
      }
    }
  }
}

std::optional<Frame> Renderer::continueSplit(SplitFrame& frame) {
  State& s = *state_;
  const FrameSettings& settings = frame.settings_;
  SceneBuffers& scene = s.scene(frame.scene_);
  LightingTechnique& technique = s.splitTechnique(settings.technique);
  SceneEnvironment* environment = s.environmentFor(frame.scene_, settings);
  if (s.frameBudgetMs > 0.0) {
    // Over the budget, or projected past it by its parts measured so far once it has taken a
    // share of it (the first parts' estimates are rough, and a frame is not refused on them).
    const double projected = frame.projectedMilliseconds();
    const bool projectedOver = frame.elapsedMs_ >= kProjectAfterShare * s.frameBudgetMs &&
                               projected > s.frameBudgetMs;
    if (frame.elapsedMs_ > s.frameBudgetMs || projectedOver) {
      char detail[256];
      std::snprintf(detail, sizeof detail,
                    "the frame would take the renderer about %.1f s (%.1f s of it taken in %u "
                    "parts), over the budget of %.1f s a frame",
                    projected / 1000.0, frame.elapsedMs_ / 1000.0, frame.submissions_,
                    s.frameBudgetMs / 1000.0);
      throw FrameBudgetError(detail, s.frameBudgetMs, frame.elapsedMs_, projected);
    }
  }
  s.runSplitPart(frame);
  while (frame.step_ < frame.steps_.size() &&
         frame.nextUnit_ >= frame.steps_[frame.step_].units) {
    ++frame.step_;
    frame.nextUnit_ = 0;
  }
  if (frame.step_ < frame.steps_.size()) return std::nullopt;
  Frame result = s.readFrame(s.split, State::metaOf(scene, environment, settings), settings,
                             technique);
  result.passes = frame.passes_;
  result.submissions = frame.submissions_;
  result.culling.listsGrew = frame.listsGrew_;
  s.costs[frame.scene_] = {settings.technique, pixelsOf(settings), scene.lightCount,
                           frame.elapsedMs_ - frame.subFrameStartMs_};
  if (!frame.resolve_) return result;
  // A sub-frame of a taa or ssaa frame: the next one starts (its first part), or the frame is
  // resolved. The budget counts the sub-frames together (elapsedMs_ goes on).
  SubFrameResolve& resolve = *frame.resolve_;
  resolve.add(std::move(result));
  if (resolve.added() < resolve.frames().size()) {
    frame.settings_ = resolve.frames()[resolve.added()];
    frame.submissions_ = 0;
    frame.subFrameStartMs_ = frame.elapsedMs_;
    s.startSplit(frame);
    return std::nullopt;
  }
  return resolve.resolve();
}

}  // namespace myriad::render
