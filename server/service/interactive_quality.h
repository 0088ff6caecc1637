// The interactive quality of a stream (GET .../stream?interactive=FPS): while the session keeps
// changing (a camera drag, a slider), the stream's frames are cheaper (a smaller render scale that
// the client scales up, no anti-aliasing, no sun shadows, a lower JPEG quality), the scale chosen
// from the measured time of the frames before so that FPS frames a second hold; once the session
// has stopped changing for a settle time, one full-quality frame (the still) follows. Lights that
// animate change every frame, so an animated session's stream stays interactive while it animates,
// at half the rate (animation is watched, not steered: no input waits on it, so it takes twice the
// time and about twice the pixels of a frame while dragging), with its own learnt scale; the still
// follows when the animation stops. Chosen by the server from its own frame times, so every
// client of the protocol gets it by asking.
//
// Pure: no HTTP, no Vulkan, no clock of its own (times are passed in), so it is unit-tested.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>

#include "service/frame_query.h"

namespace myriad::service {

class InteractiveQuality {
 public:
  using Clock = std::chrono::steady_clock;

  // The settle time: twice the longest of the last kGaps gaps between changes of the interaction
  // (the page sends camera changes about every 33 ms and slider changes every 80-100 ms; on a
  // busy machine its requests come irregularly, and a still rendered mid-drag holds the stream
  // for a whole full-quality frame), and at least a quarter of the last full-quality frame's time
  // (what a still started too early costs: on an idle lavapipe about 200 ms, so 60 ms; on a loaded
  // one seconds, so a longer wait), within these bounds.
  static constexpr std::chrono::milliseconds kMinSettle{60};
  static constexpr std::chrono::milliseconds kMaxSettle{400};
  static constexpr size_t kGaps = 4;
  // Changes further apart than this belong to different interactions.
  static constexpr std::chrono::milliseconds kSameInteraction{1000};
  // Render scale bounds (of each side) and its step: the scale moves in steps of 1/16, and only
  // when the frame time is off its budget by more than kTolerance, so that the frame targets
  // (rebuilt at each new size) change rarely.
  static constexpr double kMinScale = 0.125;  // 160x90 of 1280x720: a preview, but a moving one
  static constexpr double kStartScale = 0.5;
  static constexpr double kScaleStep = 1.0 / 16.0;
  static constexpr double kTolerance = 0.15;
  // The scale goes up only to a size whose last frame, if measured in the last kProbeFrames
  // frames of that motion, fitted the budget. A frame's cost is not proportional to its pixels at
  // the smallest scales (on llvmpipe the G-buffer's vertex work and each pass's start are most of
  // a 160x90 frame), so the step from the pixel model went up, the frame there was over budget
  // and the next went down again: 160x90 and 240x135 alternated frame by frame, each remaking its
  // slot's targets. A too slow size is tried again after kProbeFrames (~2 s at 24 fps): the
  // machine may have become less busy.
  static constexpr uint32_t kProbeFrames = 48;
  // Animated frames come back to back, so the stream shows about 1 / frame time: a scale held
  // within kTolerance around the budget showed the rate within 15% around it, half the time
  // below (the page's animated 11.8 fps against its 12 on lavapipe, docs/performance.md). So
  // for animation the budget is a ceiling on a frame's cost as shown (its render and encode plus
  // the write and the loop's turn before it: stream.cpp measures both): a frame over it steps
  // the scale down, and a scale is tried again upwards only where its last frame fitted
  // (kProbeFrames); the rate then stays at or above the target, at a scale about a step smaller.
  // A steered scale moves on the median of the last kRecent frames at that scale, not on one
  // frame: on a CPU renderer that shares its cores with the page, a frame now and then takes far
  // longer than its neighbours (the browser's own work), and stepping down on one (then holding
  // the smaller scale for kProbeFrames, the larger one's last frame having missed) kept the
  // page's drags at 5/16 in one run where 6/16 held the rate in the next (issue 30's page
  // benchmark, docs/performance.md). Until two frames are measured at a scale it moves only when
  // one is kFarOff off the budget either way (a new size's first frame also pays for its targets).
  static constexpr size_t kRecent = 3;
  static constexpr double kFarOff = 2.0;
  // An interactive frame's share of 1 / FPS: the rest is the wait for the change, the write and
  // the client's input, requests and decode. Half: on a CPU renderer a frame's wall time is all
  // of the machine's cores, and a client on the same machine (the web client on lavapipe) needs
  // the other half to send the changes and show the frames (docs/performance.md: 0.8 dragged at
  // 16.1 fps median, 0.4-0.6 at 18.5, same minutes).
  static constexpr double kBudgetShare = 0.5;
  // JPEG quality of interactive frames (at most the stream's own).
  static constexpr int kInteractiveJpegQuality = 50;
  // Interactive frames draw meshes' coarser versions where those differ by at most this many
  // pixels (FrameSettings::geometryErrorPixels): at 1/8 scale the G-buffer's vertex work, not its
  // pixels, was most of a frame on llvmpipe.
  static constexpr float kGeometryErrorPixels = 0.5f;

  explicit InteractiveQuality(uint32_t targetFps) : targetFps_(targetFps) {}

  // The session changed (its version moved), seen at `at`.
  void sawChange(Clock::time_point at);

  // True while the last change is younger than the settle time: frames are interactive.
  bool moving(Clock::time_point now) const { return seen_ && now < settlesAt(); }
  // When the current interaction ends unless another change comes.
  Clock::time_point settlesAt() const { return lastChange_ + settle_; }
  Clock::duration settle() const { return settle_; }

  // What changes the picture: a client steering it (a drag, a slider) or only the lights'
  // animation. Each has its own frame rate and learnt scale.
  enum class Motion { Steered, Animated };

  double scale(Motion motion) const { return scales_[index(motion)]; }
  // The frames a second held: the stream's interactive rate, half of it (at least 1) for animation.
  uint32_t targetFps(Motion motion) const {
    return motion == Motion::Animated ? std::max<uint32_t>(1, targetFps_ / 2) : targetFps_;
  }

  // `full` made interactive: the size scaled (at least 1 pixel a side), JPEG quality lowered,
  // FrameRequest::interactive set (the session frame then drops anti-aliasing and shadows).
  FrameRequest degrade(const FrameRequest& full, Motion motion) const;

  // A full-quality frame of the stream took `took` from submission to encoded (0: not rendered
  // for this stream, e.g. taken from another stream's render): the still's cost, for the settle.
  void measuredFull(Clock::duration took);

  // An interactive frame rendered at `usedScale` took `took` from submission to encoded: the
  // next scale (of that motion) is the one whose pixels fit the budget, cost taken as
  // proportional to pixels.
  void measured(Motion motion, double usedScale, Clock::duration took);

 private:
  uint32_t targetFps_;
  bool seen_ = false;
  Clock::time_point lastChange_{};
  std::array<Clock::duration, kGaps> gaps_{};  // the interaction's last gaps (zero: none yet)
  size_t nextGap_ = 0;
  Clock::duration fullCost_{};  // the last full-quality frame's time
  Clock::duration settle_ = kMinSettle;
  static size_t index(Motion motion) { return motion == Motion::Animated ? 1 : 0; }
  std::array<double, 2> scales_{kStartScale, kStartScale};  // learnt per Motion
  // The scale steps, kMinScale to 1, and what was last measured at each, per Motion.
  static constexpr size_t kSteps = size_t((1.0 - kMinScale) / kScaleStep) + 1;
  static_assert(kMinScale + (kSteps - 1) * kScaleStep == 1.0);
  static size_t stepOf(double scale);
  struct StepTime {
    double ms = 0.0;
    uint64_t frame = 0;  // the Motion's frame count when measured; 0: never
  };
  std::array<std::array<StepTime, kSteps>, 2> stepTimes_{};
  std::array<uint64_t, 2> frames_{};  // interactive frames measured, per Motion
  // The last steered frames measured at recentScale_, newest last (at most kRecent).
  std::array<double, kRecent> recentMs_{};
  size_t recentCount_ = 0;
  double recentScale_ = 0.0;
  // The steered cost to decide on at `scale` (kRecent says how), or NaN: hold it.
  double steeredCost(double scale, double ms, double budgetMs);
};

}  // namespace myriad::service
