#include "image_compare.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>

namespace myriad::test {

int maxDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  REQUIRE(a.size() == b.size());
  int worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(int(a[i]) - int(b[i])));
  return worst;
}

int pixelDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, size_t pixel,
                    int channels) {
  const size_t at = pixel * size_t(channels);
  int worst = 0;
  for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(a[at + c]) - int(b[at + c])));
  return worst;
}

size_t pixelsOver(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int tolerance,
                  int channels) {
  REQUIRE(a.size() == b.size());
  size_t over = 0;
  for (size_t p = 0; p < a.size() / size_t(channels); ++p) {
    if (pixelDifference(a, b, p, channels) > tolerance) ++over;
  }
  return over;
}

double fractionDifferent(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                         int tolerance, int channels) {
  size_t over = pixelsOver(a, b, tolerance, channels);
  return double(over) / double(a.size() / size_t(channels));
}

}  // namespace myriad::test
