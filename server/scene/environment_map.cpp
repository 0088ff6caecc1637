#include "scene/environment_map.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace myriad::scene {

namespace {

// Input texels [first, last) whose centres (i + 0.5) fall in output texel `o` of `outSize`
// across an input of `inSize`; empty when none does, then `first` is the one under its centre.
struct Span {
  uint32_t first;
  uint32_t last;
};

Span inputSpan(uint32_t o, uint32_t outSize, uint32_t inSize) {
  const double scale = double(inSize) / double(outSize);
  const double begin = o * scale;
  const double end = (o + 1) * scale;
  auto firstCentreAtOrAfter = [](double x) {
    return uint32_t(std::max(0.0, std::ceil(x - 0.5)));
  };
  uint32_t first = std::min(firstCentreAtOrAfter(begin), inSize);
  uint32_t last = std::min(firstCentreAtOrAfter(end), inSize);
  if (first >= last) {
    uint32_t under = std::min(uint32_t((o + 0.5) * scale), inSize - 1);
    return {under, under};
  }
  return {first, last};
}

}  // namespace

EnvironmentImage resampleEquirect(const std::vector<float>& rgb, uint32_t width, uint32_t height) {
  if (width == 0 || height == 0 || rgb.size() != size_t(width) * height * 3) {
    throw std::invalid_argument("an environment image needs width x height x 3 floats");
  }
  EnvironmentImage out;
  out.rgb.resize(size_t(kEnvironmentWidth) * kEnvironmentHeight * 3);
  for (uint32_t y = 0; y < kEnvironmentHeight; ++y) {
    const Span rows = inputSpan(y, kEnvironmentHeight, height);
    for (uint32_t x = 0; x < kEnvironmentWidth; ++x) {
      const Span columns = inputSpan(x, kEnvironmentWidth, width);
      double sum[3] = {0, 0, 0};
      uint32_t rowEnd = rows.last > rows.first ? rows.last : rows.first + 1;
      uint32_t columnEnd = columns.last > columns.first ? columns.last : columns.first + 1;
      for (uint32_t j = rows.first; j < rowEnd; ++j) {
        for (uint32_t i = columns.first; i < columnEnd; ++i) {
          const float* p = &rgb[(size_t(j) * width + i) * 3];
          for (int c = 0; c < 3; ++c) sum[c] += p[c];
        }
      }
      const double count = double(rowEnd - rows.first) * double(columnEnd - columns.first);
      float* q = &out.rgb[(size_t(y) * kEnvironmentWidth + x) * 3];
      for (int c = 0; c < 3; ++c) q[c] = float(sum[c] / count);
    }
  }
  return out;
}

}  // namespace myriad::scene
