#include "encode/raw.h"

#include <bit>
#include <stdexcept>
#include <string>

namespace myriad::encode {

std::vector<uint8_t> packRaw(uint32_t width, uint32_t height, std::span<const float> pixels,
                             size_t channels) {
  const size_t count = size_t(width) * height;
  if (pixels.size() != count * 4) {
    throw std::invalid_argument("raw frame holds " + std::to_string(pixels.size()) +
                                " floats, not 4 per pixel of " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  if (channels < 1 || channels > 4) {
    throw std::invalid_argument("raw frames keep 1 to 4 channels per pixel, not " +
                                std::to_string(channels));
  }
  std::vector<uint8_t> bytes(count * channels * sizeof(float));
  uint8_t* out = bytes.data();
  for (size_t p = 0; p < count; ++p) {
    for (size_t c = 0; c < channels; ++c) {
      uint32_t bits = std::bit_cast<uint32_t>(pixels[p * 4 + c]);
      // Little-endian whatever the host: byte k holds bits 8k..8k+7.
      for (int k = 0; k < 4; ++k) *out++ = uint8_t(bits >> (8 * k));
    }
  }
  return bytes;
}

}  // namespace myriad::encode
