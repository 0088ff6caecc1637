// Anti-aliasing made of sub-frames (Antialias::Taa, Antialias::Ssaa; FrameSettings::
// resolvedFromSubFrames): the renderer renders a frame of these as ordinary frames with
// Antialias::None (the sub-frames) and resolves their 8-bit pixels on the host into the frame
// asked for. Whole frames (Renderer::beginFrame) render every sub-frame but the last at once and
// leave the last in flight; split frames (Renderer::beginSplit) run them one after another, each
// in its own parts. The rules (docs/ARCHITECTURE.md, "Anti-aliasing"):
//  - ssaa: sub-frames of `final` alone at 2x2 the size (kSsaaOffsets: two, jittered by a quarter
//    of a doubled pixel), each box-downsampled 2x2 -> 1 in linear light (sRGB decoded, averaged,
//    encoded again), the two averaged. A frame whose doubled size exceeds the
//    device's largest image or kMaxSupersampledPixels falls back to taa (its "resolve" pass
//    says which: resolveName).
//  - taa: kTaaSamples sub-frames of `final` alone at the asked size, the projection jittered by
//    taaJitter(0..7) (Halton 2,3), resolved in order: the first is the history; each next one
//    is blended into it after the history is clamped to the 3x3 neighbourhood's YCoCg box of
//    the new sub-frame, with weight max(1 / (k + 1), kTaaBlend). The same request gives the same
//    bytes (no state carries between frames), and every still has its 8 samples.
//  - data views: a multi-target frame (alsoRead) renders one more sub-frame, the frame as asked
//    with Antialias::None, unjittered, at the asked size, whose extras and labels the answer
//    carries: byte for byte those of `none`. Frames of any other target or raw never come here.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "render/frame.h"

namespace myriad::render {

inline constexpr uint32_t kTaaSamples = 8;
inline constexpr float kTaaBlend = 0.1f;  // the exponential blend's weight once history is long
// The sub-pixel offsets (in the doubled image's pixels) of an ssaa frame's sub-frames at 2x2
// the size: two, a quarter of a doubled pixel apart along the diagonal, so each pixel averages 8
// samples, a checkerboard of its 4x4 lattice (at 1/8, 3/8, 5/8, 7/8). One unjittered sub-frame
// (the ordered 2x2 grid alone) cut the edge error against a 4x4 supersampled reference by 68%
// (tests/antialias_modes_tests.cpp; issue 36 wants 75%: a 2x2 grid's coverage is quantised to
// quarters, the reference's to sixteenths), two by more (the test's figure).
inline const std::array<glm::vec2, 2> kSsaaOffsets = {glm::vec2(-0.25f, -0.25f),
                                                      glm::vec2(0.25f, 0.25f)};
// The most pixels an ssaa frame renders (its 2x2 sub-frame): 4K UHD's doubled, 7680x4320.
inline constexpr uint64_t kMaxSupersampledPixels = 7680ull * 4320ull;

// Sub-frame `index`'s sub-pixel offset in pixels, each within (-0.5, 0.5): Halton (2, 3) at
// index + 1.
glm::vec2 taaJitter(uint32_t index);

// Whether an ssaa frame of this size renders supersampled on a device whose images are at most
// `maxDimension` across (else it falls back to taa).
bool supersampleFits(uint32_t width, uint32_t height, uint32_t maxDimension);

class SubFrameResolve {
 public:
  // `asked`: a frame with resolvedFromSubFrames().
  SubFrameResolve(const FrameSettings& asked, uint32_t maxDimension);

  // The sub-frames to render, in order.
  const std::vector<FrameSettings>& frames() const { return frames_; }
  // The mode resolved: the asked one, or Taa for an ssaa frame too large.
  Antialias mode() const { return mode_; }
  // Hands over sub-frame number added() (in frames()' order).
  void add(Frame frame);
  size_t added() const { return added_; }
  // Once every sub-frame was added: the frame asked for (RGBA, not borrowed, not YCbCr).
  Frame resolve();

 private:
  FrameSettings asked_;
  Antialias mode_;
  std::vector<FrameSettings> frames_;
  size_t dataFrame_ = SIZE_MAX;  // index of the data views' sub-frame, if any
  size_t added_ = 0;
  uint32_t pictures_ = 0;  // picture sub-frames added
  std::vector<float> color_;  // linear RGBA at the asked size: the history or the sum
  std::vector<glm::vec3> current_;  // taa: the sub-frame being added, YCoCg (one buffer for all 8)
  Frame base_;               // the data views' sub-frame, or the last picture's (metadata)
  std::vector<PassTiming> passes_;
  FrameTimes times_;
  uint32_t submissions_ = 0;
  bool madeTargets_ = false;
  double resolveMs_ = 0.0;
};

}  // namespace myriad::render
