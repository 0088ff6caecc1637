// Myriad's own PNG writer: rows filtered here, the zlib stream made by libdeflate in one call,
// chunks framed here. Chosen over libpng by measurement (docs/performance.md "PNG encoding"): on a
// 1920x1080 `final` frame libpng spends most of its time in zlib's streaming deflate; libdeflate
// compresses the whole buffer at once several times faster for about the same size. Decoders
// cannot tell the difference: the file is a standard PNG (tests decode it with libpng).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace myriad::encode {

// The PNG row filters (PNG spec 9.2); one filter for every row.
enum class PngFilter : uint8_t { None = 0, Sub = 1, Up = 2, Average = 3, Paeth = 4 };

// What a PNG is made with: libdeflate's level (0 = stored, 1 fastest .. 12 smallest) and the
// filter.
struct PngSettings {
  int level = 1;
  PngFilter filter = PngFilter::Sub;
  // Threads for an image of at least kParallelPngPixels: 0 = half the cores, at most 8 (one on a
  // machine of 2-3 cores); 1 = this thread alone. In parallel the rows are filtered in strips and
  // each strip deflated by zlib on its own thread (flushed to a byte boundary, joined into one
  // zlib stream, as pigz does), since libdeflate's whole-buffer streams cannot be joined.
  unsigned threads = 0;
};
inline constexpr uint64_t kParallelPngPixels = 1280ull * 720;

// What the pixels are: 8-bit RGBA (4 bytes a pixel), 8-bit RGB (3) or 16-bit grey (2 bytes a
// pixel, given as native uint16 values; written big-endian as PNG stores them).
enum class PngPixels { Rgba8, Rgb8, Grey16 };

// tEXt chunks written before the image data: keyword (1-79 Latin-1 characters), text.
using PngText = std::vector<std::pair<std::string, std::string>>;

// A PNG of `pixels` (tightly packed rows, top row first). RGBA whose alpha is 255 everywhere (a
// rendered frame) is written as RGB: a quarter less to filter and deflate, the same pixels to
// any decoder. Throws std::invalid_argument when the
// size is 0, above PNG's limit, or `pixels` is not width * height pixels of `kind`, and
// std::bad_alloc when out of memory.
std::vector<uint8_t> writePng(uint32_t width, uint32_t height, PngPixels kind,
                              std::span<const uint8_t> pixels, const PngSettings& settings,
                              const PngText& text = {});

}  // namespace myriad::encode
