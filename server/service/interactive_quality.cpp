#include "service/interactive_quality.h"

#include <algorithm>
#include <cmath>

namespace myriad::service {

void InteractiveQuality::sawChange(Clock::time_point at) {
  const Clock::duration gap = at - lastChange_;
  if (seen_ && gap < kSameInteraction) {
    gaps_[nextGap_] = gap;
    nextGap_ = (nextGap_ + 1) % kGaps;
  } else {
    // The first change of a new interaction: no rhythm known yet.
    gaps_.fill(Clock::duration::zero());
  }
  const Clock::duration longest = *std::max_element(gaps_.begin(), gaps_.end());
  settle_ = std::clamp<Clock::duration>(std::max(2 * longest, fullCost_ / 4), kMinSettle,
                                        kMaxSettle);
  seen_ = true;
  lastChange_ = at;
}

void InteractiveQuality::measuredFull(Clock::duration took) {
  if (took > Clock::duration::zero()) fullCost_ = took;
}

FrameRequest InteractiveQuality::degrade(const FrameRequest& full, Motion motion) const {
  const double scale = this->scale(motion);
  FrameRequest out = full;
  out.settings.width = std::max<uint32_t>(
      1, static_cast<uint32_t>(std::lround(full.settings.width * scale)));
  out.settings.height = std::max<uint32_t>(
      1, static_cast<uint32_t>(std::lround(full.settings.height * scale)));
  out.quality = std::min(full.quality, kInteractiveJpegQuality);
  out.interactive = true;
  return out;
}

void InteractiveQuality::measured(Motion motion, double usedScale, Clock::duration took) {
  const double ms = std::chrono::duration<double, std::milli>(took).count();
  if (!(ms > 0.0) || targetFps_ == 0) return;
  const double budgetMs = kBudgetShare * 1000.0 / targetFps(motion);
  const size_t m = index(motion);
  const double cost = motion == Motion::Steered ? steeredCost(usedScale, ms, budgetMs) : ms;
  ++frames_[m];
  if (std::isnan(cost)) return;
  auto& times = stepTimes_[m];
  times[stepOf(usedScale)] = {cost, frames_[m]};
  const double ratio = budgetMs / cost;
  // Steered frames keep their scale within kTolerance of the budget either way; animated ones
  // hold it as a ceiling (the header says why): any frame over it steps down.
  const double over = motion == Motion::Animated ? 0.0 : kTolerance;
  if (ratio >= 1.0 - over && ratio <= 1.0 + kTolerance) return;
  // Pixels go with the square of the scale; half of the way there per frame, so that one odd
  // frame (another session's frame in between, a busy core) does not swing it to a bound.
  const double wanted = usedScale * std::sqrt(ratio);
  const double next = usedScale + 0.5 * (wanted - usedScale);
  double stepped = std::round(next / kScaleStep) * kScaleStep;
  if (stepped == usedScale) stepped += ratio > 1.0 ? kScaleStep : -kScaleStep;
  stepped = std::clamp(stepped, kMinScale, 1.0);
  // Up no further than the sizes that fitted when last measured (kProbeFrames says why).
  while (stepped > usedScale) {
    const StepTime& known = times[stepOf(stepped)];
    const bool recent = known.frame > 0 && frames_[m] - known.frame < kProbeFrames;
    if (!recent || known.ms <= budgetMs * (1.0 + over)) break;
    stepped -= kScaleStep;
  }
  scales_[m] = stepped;
}

double InteractiveQuality::steeredCost(double scale, double ms, double budgetMs) {
  if (scale != recentScale_) {
    recentScale_ = scale;
    recentCount_ = 0;
  } else if (recentCount_ == kRecent) {
    std::copy(recentMs_.begin() + 1, recentMs_.end(), recentMs_.begin());
    --recentCount_;
  }
  recentMs_[recentCount_++] = ms;
  if (recentCount_ == 1) {
    const double ratio = budgetMs / ms;
    return ratio < 1.0 / kFarOff || ratio > kFarOff ? ms : std::nan("");
  }
  const double low = std::min(recentMs_[0], recentMs_[1]);
  const double high = std::max(recentMs_[0], recentMs_[1]);
  // Two frames: both must be off the same way, so the one nearer the budget decides.
  if (recentCount_ == 2) return low > budgetMs ? low : high < budgetMs ? high : budgetMs;
  static_assert(kRecent == 3, "the median below is of three");
  return std::clamp(recentMs_[2], low, high);
}

size_t InteractiveQuality::stepOf(double scale) {
  const long step = std::lround((scale - kMinScale) / kScaleStep);
  return size_t(std::clamp<long>(step, 0, long(kSteps) - 1));
}

}  // namespace myriad::service
