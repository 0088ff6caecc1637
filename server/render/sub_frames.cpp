// Anti-aliasing made of sub-frames (render/sub_frames.h): the plan of a taa or ssaa frame's
// sub-frames, their resolve on the host, and the renderer's whole-frame entry points around them.
#include "render/sub_frames.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <utility>

#include "render/renderer.h"
#include "render/renderer_state.h"

namespace myriad::render {

namespace {

float halton(uint32_t index, uint32_t base) {
  float f = 1.0f, r = 0.0f;
  while (index > 0) {
    f /= float(base);
    r += f * float(index % base);
    index /= base;
  }
  return r;
}

// sRGB code -> linear light.
const std::array<float, 256>& srgbToLinear() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double c = i / 255.0;
      t[i] = float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

// Linear light in [0, 1] at 16 bits -> the nearest sRGB code (a step of 1/65535 moves the code
// by at most 0.05 near black, where the curve is steepest).
constexpr uint32_t kEncodeSteps = 65535;
const std::vector<uint8_t>& linearToSrgb() {
  static const std::vector<uint8_t> table = [] {
    std::vector<uint8_t> t(kEncodeSteps + 1);
    for (uint32_t i = 0; i <= kEncodeSteps; ++i) {
      const double v = double(i) / kEncodeSteps;
      const double c = v <= 0.0031308 ? v * 12.92 : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
      t[i] = uint8_t(std::clamp(std::lround(c * 255.0), 0l, 255l));
    }
    return t;
  }();
  return table;
}

uint8_t encode(float linear) {
  const float v = std::clamp(linear, 0.0f, 1.0f);
  return linearToSrgb()[uint32_t(v * float(kEncodeSteps) + 0.5f)];
}

// Linear RGB <-> YCoCg (the neighbourhood clamp's space: luma apart from chroma).
glm::vec3 toYCoCg(glm::vec3 c) {
  return {0.25f * c.r + 0.5f * c.g + 0.25f * c.b, 0.5f * c.r - 0.5f * c.b,
          -0.25f * c.r + 0.5f * c.g - 0.25f * c.b};
}
glm::vec3 fromYCoCg(glm::vec3 c) { return {c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z}; }

// Runs f(y0, y1) over the rows [0, rows) in bands, on up to kResolveThreads threads when there
// are many pixels (each pixel is computed alone: the result does not depend on the bands).
constexpr uint32_t kResolveThreads = 8;
constexpr size_t kPixelsPerThread = 1u << 17;
template <class F>
void forRows(uint32_t rows, size_t rowPixels, const F& f) {
  const size_t byWork = size_t(rows) * rowPixels / kPixelsPerThread + 1;
  const uint32_t threads = uint32_t(std::min<size_t>(
      {size_t(std::max(1u, std::thread::hardware_concurrency())), size_t(kResolveThreads), byWork,
       size_t(std::max(rows, 1u))}));
  if (threads <= 1) {
    f(0u, rows);
    return;
  }
  const uint32_t band = (rows + threads - 1) / threads;
  std::vector<std::thread> pool;
  for (uint32_t y0 = band; y0 < rows; y0 += band) pool.emplace_back(f, y0, std::min(rows, y0 + band));
  f(0u, std::min(rows, band));
  for (std::thread& t : pool) t.join();
}

void addPasses(std::vector<PassTiming>& sum, const std::vector<PassTiming>& passes) {
  for (const PassTiming& p : passes) {
    auto it = std::find_if(sum.begin(), sum.end(), [&](const PassTiming& s) { return s.name == p.name; });
    if (it == sum.end()) {
      sum.push_back(p);
    } else {
      it->milliseconds += p.milliseconds;
    }
  }
}

}  // namespace

glm::vec2 taaJitter(uint32_t index) {
  return {halton(index + 1, 2) - 0.5f, halton(index + 1, 3) - 0.5f};
}

bool supersampleFits(uint32_t width, uint32_t height, uint32_t maxDimension) {
  return uint64_t(width) * 2 <= maxDimension && uint64_t(height) * 2 <= maxDimension &&
         uint64_t(width) * height * 4 <= kMaxSupersampledPixels;
}

SubFrameResolve::SubFrameResolve(const FrameSettings& asked, uint32_t maxDimension)
    : asked_(asked), mode_(asked.antialias) {
  if (!asked.resolvedFromSubFrames()) {
    throw std::logic_error("a frame of sub-frames is taa or ssaa on the 8-bit final image");
  }
  if (mode_ == Antialias::Ssaa && !supersampleFits(asked.width, asked.height, maxDimension)) {
    mode_ = Antialias::Taa;  // too large to double: the same quality class at 1x memory
  }
  FrameSettings picture = asked;
  picture.antialias = Antialias::None;
  picture.alsoRead.clear();
  picture.yuv420 = false;
  picture.borrowPixels = false;
  picture.jitter = {0.0f, 0.0f};
  if (!asked.alsoRead.empty()) {
    // The data views: the frame as asked, unjittered, at its size, without anti-aliasing.
    FrameSettings data = asked;
    data.antialias = Antialias::None;
    data.yuv420 = false;
    data.borrowPixels = false;
    data.jitter = {0.0f, 0.0f};
    dataFrame_ = frames_.size();
    frames_.push_back(std::move(data));
  }
  if (mode_ == Antialias::Ssaa) {
    picture.width *= 2;
    picture.height *= 2;
    // A coarser mesh's error is bounded in output pixels: twice as many sub-frame pixels.
    picture.geometryErrorPixels *= 2.0f;
    for (const glm::vec2 offset : kSsaaOffsets) {
      picture.jitter = offset;
      frames_.push_back(picture);
    }
  } else {
    for (uint32_t i = 0; i < kTaaSamples; ++i) {
      picture.jitter = taaJitter(i);
      frames_.push_back(picture);
    }
  }
}

void SubFrameResolve::add(Frame frame) {
  if (added_ >= frames_.size()) throw std::logic_error("every sub-frame was added");
  const FrameSettings& settings = frames_[added_];
  const size_t index = added_++;
  addPasses(passes_, frame.passes);
  times_.recordMs += frame.times.recordMs;
  times_.fenceWaitMs += frame.times.fenceWaitMs;
  times_.copyMs += frame.times.copyMs;
  if (frame.times.gpuMs >= 0.0) times_.gpuMs = std::max(times_.gpuMs, 0.0) + frame.times.gpuMs;
  if (index == 0) times_.gpuIdleMs = frame.times.gpuIdleMs;
  submissions_ += frame.submissions;
  madeTargets_ = madeTargets_ || frame.madeTargets;
  if (index == dataFrame_) {
    base_ = std::move(frame);
    base_.rgba.clear();
    base_.borrowed.reset();
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::span<const uint8_t> px = frame.pixels();
  const uint32_t w = asked_.width, h = asked_.height;
  if (frame.width != settings.width || frame.height != settings.height ||
      px.size() != size_t(settings.width) * settings.height * 4) {
    throw std::logic_error("a sub-frame came back at another size or format");
  }
  const std::array<float, 256>& lin = srgbToLinear();
  if (mode_ == Antialias::Ssaa) {
    // Box 2x2 -> 1 in linear light, the sub-frames averaged.
    if (pictures_ == 0) color_.assign(size_t(w) * h * 4, 0.0f);
    const float share = 0.25f / float(kSsaaOffsets.size());
    const size_t row = size_t(frame.width) * 4;
    forRows(h, size_t(w) * 4, [&](uint32_t y0, uint32_t y1) {
      for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = 0; x < w; ++x) {
          const uint8_t* a = px.data() + size_t(2 * y) * row + size_t(2 * x) * 4;
          const uint8_t* b = a + row;
          float* out = &color_[(size_t(y) * w + x) * 4];
          for (int c = 0; c < 3; ++c) out[c] += share * (lin[a[c]] + lin[a[4 + c]] + lin[b[c]] + lin[b[4 + c]]);
          out[3] += share * (a[3] + a[7] + b[3] + b[7]) / 255.0f;
        }
      }
    });
  } else {
    // TAA: the history (YCoCg and alpha, in color_) clamped to this sub-frame's neighbourhood,
    // then blended towards it.
    std::vector<glm::vec3>& current = current_;
    current.resize(size_t(w) * h);
    forRows(h, w, [&](uint32_t y0, uint32_t y1) {
      for (size_t i = size_t(y0) * w; i < size_t(y1) * w; ++i) {
        current[i] = toYCoCg({lin[px[4 * i]], lin[px[4 * i + 1]], lin[px[4 * i + 2]]});
      }
    });
    if (pictures_ == 0) {
      color_.resize(size_t(w) * h * 4);
      for (size_t i = 0; i < current.size(); ++i) {
        color_[4 * i] = current[i].x;
        color_[4 * i + 1] = current[i].y;
        color_[4 * i + 2] = current[i].z;
        color_[4 * i + 3] = px[4 * i + 3] / 255.0f;
      }
    } else {
      const float alpha = std::max(1.0f / float(pictures_ + 1), kTaaBlend);
      // The 3x3 box, separably: each row's 3-wide min and max (a band keeps its last three
      // rows'), then the three rows' of each pixel.
      auto horizontal = [&](uint32_t row, glm::vec3* lo, glm::vec3* hi) {
        const glm::vec3* c = &current[size_t(row) * w];
        for (uint32_t x = 0; x < w; ++x) {
          const glm::vec3 a = c[x > 0 ? x - 1 : 0], b = c[x], d = c[x + 1 < w ? x + 1 : x];
          lo[x] = glm::min(glm::min(a, b), d);
          hi[x] = glm::max(glm::max(a, b), d);
        }
      };
      forRows(h, size_t(w) * 4, [&](uint32_t y0, uint32_t y1) {
        std::vector<glm::vec3> rowLo(size_t(3) * w), rowHi(size_t(3) * w);
        int64_t cached[3] = {-1, -1, -1};
        auto rowOf = [&](uint32_t row) {
          const size_t slot = row % 3;
          if (cached[slot] != int64_t(row)) {
            horizontal(row, &rowLo[slot * w], &rowHi[slot * w]);
            cached[slot] = row;
          }
          return slot * w;
        };
        for (uint32_t y = y0; y < y1; ++y) {
          const size_t r0 = rowOf(y > 0 ? y - 1 : y), r1 = rowOf(y), r2 = rowOf(y + 1 < h ? y + 1 : y);
          for (uint32_t x = 0; x < w; ++x) {
            const glm::vec3 lo = glm::min(glm::min(rowLo[r0 + x], rowLo[r1 + x]), rowLo[r2 + x]);
            const glm::vec3 hi = glm::max(glm::max(rowHi[r0 + x], rowHi[r1 + x]), rowHi[r2 + x]);
            const size_t i = size_t(y) * w + x;
            float* hist = &color_[4 * i];
            const glm::vec3 clamped = glm::clamp(glm::vec3(hist[0], hist[1], hist[2]), lo, hi);
            const glm::vec3 blended = glm::mix(clamped, current[i], alpha);
            hist[0] = blended.x;
            hist[1] = blended.y;
            hist[2] = blended.z;
            hist[3] += alpha * (px[4 * i + 3] / 255.0f - hist[3]);
          }
        }
      });
    }
  }
  ++pictures_;
  if (dataFrame_ == SIZE_MAX) {
    base_ = std::move(frame);
    base_.rgba.clear();
    base_.borrowed.reset();
  }
  resolveMs_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

Frame SubFrameResolve::resolve() {
  if (added_ != frames_.size()) throw std::logic_error("sub-frames are missing");
  const auto start = std::chrono::steady_clock::now();
  Frame frame = std::move(base_);
  frame.width = asked_.width;
  frame.height = asked_.height;
  frame.yuv420 = false;
  frame.rgba.resize(size_t(frame.width) * frame.height * 4);
  const bool ycocg = mode_ == Antialias::Taa;
  linearToSrgb();  // made once, before the threads read it
  forRows(frame.height, frame.width, [&](uint32_t y0, uint32_t y1) {
    for (size_t i = size_t(y0) * frame.width; i < size_t(y1) * frame.width; ++i) {
      const float* c = &color_[4 * i];
      glm::vec3 rgb(c[0], c[1], c[2]);
      if (ycocg) rgb = fromYCoCg(rgb);
      frame.rgba[4 * i] = encode(rgb.r);
      frame.rgba[4 * i + 1] = encode(rgb.g);
      frame.rgba[4 * i + 2] = encode(rgb.b);
      frame.rgba[4 * i + 3] = uint8_t(std::lround(std::clamp(c[3], 0.0f, 1.0f) * 255.0f));
    }
  });
  resolveMs_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  frame.passes = std::move(passes_);
  // The host's resolve, named as the pass of a frame of sub-frames ("resolve-taa" and
  // "resolve-ssaa": an ssaa frame too large to double says resolve-taa).
  frame.passes.push_back({"resolve-" + std::string(antialiasName(mode_)), resolveMs_});
  frame.times.recordMs = times_.recordMs;
  frame.times.fenceWaitMs = times_.fenceWaitMs;
  frame.times.copyMs = times_.copyMs + resolveMs_;
  frame.times.gpuMs = times_.gpuMs;
  frame.times.gpuIdleMs = times_.gpuIdleMs;
  frame.submissions = submissions_;
  frame.madeTargets = madeTargets_;
  color_ = {};
  current_ = {};
  return frame;
}

// Whole frames (renderer.h): every sub-frame but the last now, the last in flight in its slot.
uint32_t Renderer::beginFrame(SceneId id, const FrameSettings& settings) {
  if (!settings.resolvedFromSubFrames()) return beginWhole(id, settings);
  checkSize(settings, maxDimension());
  if (!canBegin()) throw std::logic_error("every frame slot is in flight");
  auto resolve = std::make_shared<SubFrameResolve>(settings, maxDimension());
  const std::vector<FrameSettings>& frames = resolve->frames();
  for (size_t i = 0; i + 1 < frames.size(); ++i) resolve->add(finishWhole(beginWhole(id, frames[i])));
  const uint32_t slot = beginWhole(id, frames.back());
  state_->slots[slot]->resolve = std::move(resolve);
  return slot;
}

Frame Renderer::finishFrame(uint32_t slot) {
  std::shared_ptr<SubFrameResolve> resolve;
  if (slot < state_->slots.size() && state_->slots[slot]->inFlight) {
    resolve = std::move(state_->slots[slot]->resolve);
  }
  Frame frame = finishWhole(slot);
  if (!resolve) return frame;
  resolve->add(std::move(frame));
  return resolve->resolve();
}

}  // namespace myriad::render
