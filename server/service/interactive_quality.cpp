#include "service/interactive_quality.h"

#include <algorithm>
#include <cmath>

namespace myriad::service {

void InteractiveQuality::sawChange(Clock::time_point at) {
  if (seen_) {
    const Clock::duration gap = at - lastChange_;
    if (gap < kSameInteraction) {
      settle_ = std::clamp<Clock::duration>(2 * gap, kMinSettle, kMaxSettle);
    } else {
      settle_ = kMinSettle;  // the first change of a new interaction: no rhythm known yet
    }
  }
  seen_ = true;
  lastChange_ = at;
}

FrameRequest InteractiveQuality::degrade(const FrameRequest& full) const {
  FrameRequest out = full;
  out.settings.width = std::max<uint32_t>(
      1, static_cast<uint32_t>(std::lround(full.settings.width * scale_)));
  out.settings.height = std::max<uint32_t>(
      1, static_cast<uint32_t>(std::lround(full.settings.height * scale_)));
  out.quality = std::min(full.quality, kInteractiveJpegQuality);
  out.interactive = true;
  return out;
}

void InteractiveQuality::measured(double usedScale, Clock::duration took) {
  const double ms = std::chrono::duration<double, std::milli>(took).count();
  if (!(ms > 0.0) || targetFps_ == 0) return;
  const double budgetMs = kBudgetShare * 1000.0 / targetFps_;
  const double ratio = budgetMs / ms;
  if (std::abs(ratio - 1.0) <= kTolerance) return;
  // Pixels go with the square of the scale; half of the way there per frame, so that one odd
  // frame (another session's frame in between, a busy core) does not swing it to a bound.
  const double wanted = usedScale * std::sqrt(ratio);
  const double next = usedScale + 0.5 * (wanted - usedScale);
  double stepped = std::round(next / kScaleStep) * kScaleStep;
  if (stepped == usedScale) stepped += ratio > 1.0 ? kScaleStep : -kScaleStep;
  scale_ = std::clamp(stepped, kMinScale, 1.0);
}

}  // namespace myriad::service
