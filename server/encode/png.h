// PNG encoding of rendered frames (and decoding, for tests and tools). Plain CPU code: runs on the
// HTTP worker threads, never on the render thread.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace myriad::encode {

// libpng reported an error (corrupt input when decoding, out of memory when encoding).
class PngError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Encodes tightly packed RGBA8 rows, top row first, as an 8-bit RGBA PNG.
// Throws std::invalid_argument when rgba.size() != width * height * 4 or a size is 0 or above
// the PNG limit, and PngError when libpng fails.
std::vector<uint8_t> encodePng(uint32_t width, uint32_t height, std::span<const uint8_t> rgba);

struct DecodedImage {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;  // tightly packed RGBA8 rows, top row first

  // The RGBA of pixel (x, y); no bounds check beyond the vector's own.
  const uint8_t* pixel(uint32_t x, uint32_t y) const { return &rgba[(size_t(y) * width + x) * 4]; }
};

// Decodes any PNG (any bit depth, palette, grey or alpha) to RGBA8. Throws PngError when `png`
// is not a valid PNG.
DecodedImage decodePng(std::span<const uint8_t> png);

}  // namespace myriad::encode
