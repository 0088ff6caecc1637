#include "encode/raw.h"

#include <bit>
#include <cstring>
#include <stdexcept>
#include <string>

namespace myriad::encode {

std::vector<uint8_t> packRaw(const render::Frame& frame, render::Target target) {
  const size_t pixels = size_t(frame.width) * frame.height;
  if (frame.data.size() != pixels * 4) {
    throw std::invalid_argument("raw frame holds " + std::to_string(frame.data.size()) +
                                " floats, not 4 per pixel of " + std::to_string(frame.width) + "x" +
                                std::to_string(frame.height));
  }
  const size_t channels = render::rawChannels(target).size();
  std::vector<uint8_t> bytes(pixels * channels * sizeof(float));
  uint8_t* out = bytes.data();
  for (size_t p = 0; p < pixels; ++p) {
    for (size_t c = 0; c < channels; ++c) {
      uint32_t bits = std::bit_cast<uint32_t>(frame.data[p * 4 + c]);
      // Little-endian whatever the host: byte k holds bits 8k..8k+7.
      for (int k = 0; k < 4; ++k) *out++ = uint8_t(bits >> (8 * k));
    }
  }
  return bytes;
}

}  // namespace myriad::encode
