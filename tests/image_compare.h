// Pixel comparisons shared by the GPU, server and api tests: 8-bit images as byte arrays, RGB
// compared, any further channel (alpha) ignored.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace myriad::test {

// The largest difference of any byte of two images of the same size (REQUIREd).
int maxDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b);

// The largest difference of R, G, B of pixel `pixel` (`channels` bytes each, RGB first) of two
// images.
int pixelDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, size_t pixel,
                    int channels = 4);

// Pixels (`channels` bytes each, RGB first) whose colour differs by more than `tolerance` in some
// of R, G, B. The images must have the same size (REQUIREd).
size_t pixelsOver(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int tolerance,
                  int channels = 4);

// pixelsOver as a fraction of the pixel count.
double fractionDifferent(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                         int tolerance, int channels = 4);

}  // namespace myriad::test
