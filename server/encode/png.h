// PNG encoding of rendered frames (and decoding, for tests and tools). Plain CPU code: runs on the
// HTTP worker threads, never on the render thread.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "encode/png_writer.h"
#include "protocol/constants.h"

namespace myriad::encode {

// libpng reported an error (corrupt input when decoding, out of memory when encoding).
class PngError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ?compression= of PNG frames: how much CPU time to spend for how small a file. The settings
// behind each (pngSettings) and their measured size and time are in docs/performance.md
// ("PNG encoding"); the names are protocol::query::kPngCompressions, in this order.
enum class PngCompression { None, Fast, Small };
inline constexpr std::array<PngCompression, 3> kPngCompressions = {
    PngCompression::None, PngCompression::Fast, PngCompression::Small};
static_assert(kPngCompressions.size() == protocol::query::kPngCompressions.size());
std::string_view pngCompressionName(PngCompression c);
std::optional<PngCompression> parsePngCompression(std::string_view name);
// The writer's level and filter for a choice.
PngSettings pngSettings(PngCompression c);

// Encodes tightly packed RGBA8 rows, top row first, as an 8-bit RGBA PNG (encode/png_writer.h).
// Throws std::invalid_argument when rgba.size() != width * height * 4 or a size is 0 or above
// the PNG limit.
std::vector<uint8_t> encodePng(uint32_t width, uint32_t height, std::span<const uint8_t> rgba,
                               PngCompression compression = PngCompression::Fast);

// A 16-bit greyscale PNG of `values` (width * height of them, rows top first), with tEXt chunks.
std::vector<uint8_t> encodePngGrey16(uint32_t width, uint32_t height,
                                     std::span<const uint16_t> values,
                                     PngCompression compression = PngCompression::Fast,
                                     const PngText& text = {});

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

// A 16-bit greyscale PNG's samples (native uint16, rows top first), decoded by libpng; its tEXt
// chunks in `text` when given. Throws PngError when `png` is not a valid 16-bit grey PNG.
std::vector<uint16_t> decodePngGrey16(std::span<const uint8_t> png, uint32_t& width,
                                      uint32_t& height, PngText* text = nullptr);

}  // namespace myriad::encode
