#include "encode/png.h"

#include "protocol/constants.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <string>

namespace myriad::encode {

// ?compression= (png.h). Measured on a 1920x1080 `final` frame of the built-in scene with
// myriad-png-bench (docs/performance.md "PNG encoding"): libpng at zlib level 3 with SUB, the
// encoder before, spent about 3x as long as libdeflate at level 1 with SUB for a larger file;
// zlib's streaming deflate is most of libpng's time whatever the filter, and libspng (zlib too)
// is no faster at the same level. So `fast`, the default, is libdeflate level 1 + SUB (rendered
// frames are smooth horizontal gradients between hard edges, which SUB predicts well, and SUB
// costs one subtraction a byte; PAETH and UP were no smaller at level 1 and slower). `small`
// spends 3-4x the time at level 6 for a file about a tenth smaller; `none` stores the rows
// (deflate level 0): the fastest, four fifths of the raw size, for loopback where bytes are free.
// Levels 9 and up cost over 10x for a few percent more.
PngSettings pngSettings(PngCompression c) {
  switch (c) {
    case PngCompression::None: return {0, PngFilter::None};
    case PngCompression::Fast: return {1, PngFilter::Sub};
    case PngCompression::Small: return {6, PngFilter::Sub};
  }
  return {1, PngFilter::Sub};
}

std::string_view pngCompressionName(PngCompression c) {
  return protocol::query::kPngCompressions[static_cast<size_t>(c)];
}

std::optional<PngCompression> parsePngCompression(std::string_view name) {
  for (PngCompression c : kPngCompressions) {
    if (pngCompressionName(c) == name) return c;
  }
  return std::nullopt;
}

std::vector<uint8_t> encodePng(uint32_t width, uint32_t height, std::span<const uint8_t> rgba,
                               PngCompression compression) {
  return writePng(width, height, PngPixels::Rgba8, rgba, pngSettings(compression));
}

std::vector<uint8_t> encodePngGrey16(uint32_t width, uint32_t height,
                                     std::span<const uint16_t> values, PngCompression compression,
                                     const PngText& text) {
  return writePng(width, height, PngPixels::Grey16,
                  {reinterpret_cast<const uint8_t*>(values.data()), values.size_bytes()},
                  pngSettings(compression), text);
}

namespace {

struct ReadSource {
  std::span<const uint8_t> bytes;
  size_t offset = 0;
  char error[256] = {};
};

[[noreturn]] void onReadError(png_structp png, png_const_charp message) {
  auto* source = static_cast<ReadSource*>(png_get_error_ptr(png));
  std::snprintf(source->error, sizeof source->error, "%s", message);
  png_longjmp(png, 1);
}

void onReadWarning(png_structp, png_const_charp) {}

void readBytes(png_structp png, png_bytep data, size_t length) {
  auto* source = static_cast<ReadSource*>(png_get_io_ptr(png));
  if (source->bytes.size() - source->offset < length) png_error(png, "PNG is truncated");
  std::memcpy(data, source->bytes.data() + source->offset, length);
  source->offset += length;
}

struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReader() { png_destroy_read_struct(&png, &info, nullptr); }
};

// The header, after setjmp. libpng reports errors by longjmp back to this frame, which is only
// sound because no object with a destructor lives between the setjmp and the libpng calls.
bool readHeader(png_structp png, png_infop info, png_uint_32* width, png_uint_32* height,
                int* depth, int* colour) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  int interlace = 0;
  png_get_IHDR(png, info, width, height, depth, colour, &interlace, nullptr, nullptr);
  return true;
}

bool readRows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_swap(png);  // 16-bit samples to the host's (little-endian) order
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

}  // namespace

std::vector<uint16_t> decodePngGrey16(std::span<const uint8_t> bytes, uint32_t& width,
                                      uint32_t& height, PngText* text) {
  ReadSource source{bytes};
  PngReader reader;
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, onReadError, onReadWarning);
  if (!reader.png) throw PngError("PNG decoding failed: out of memory");
  reader.info = png_create_info_struct(reader.png);
  if (!reader.info) throw PngError("PNG decoding failed: out of memory");
  png_set_read_fn(reader.png, &source, readBytes);
  png_uint_32 w = 0, h = 0;
  int depth = 0, colour = 0;
  if (!readHeader(reader.png, reader.info, &w, &h, &depth, &colour)) {
    throw PngError(std::string("not a valid PNG: ") + source.error);
  }
  if (depth != 16 || colour != PNG_COLOR_TYPE_GRAY) {
    throw PngError("not a 16-bit greyscale PNG (bit depth " + std::to_string(depth) +
                   ", colour type " + std::to_string(colour) + ")");
  }
  std::vector<uint16_t> values(size_t(w) * h);
  std::vector<png_bytep> rows(h);
  for (png_uint_32 y = 0; y < h; ++y) rows[y] = reinterpret_cast<png_bytep>(&values[size_t(y) * w]);
  if (!readRows(reader.png, reader.info, rows.data())) {
    throw PngError(std::string("not a valid PNG: ") + source.error);
  }
  if (text) {
    png_textp chunks = nullptr;
    const int count = png_get_text(reader.png, reader.info, &chunks, nullptr);
    for (int i = 0; i < count; ++i) {
      text->emplace_back(chunks[i].key, std::string(chunks[i].text, chunks[i].text_length));
    }
  }
  width = w;
  height = h;
  return values;
}

DecodedImage decodePng(std::span<const uint8_t> png) {
  // The simplified API converts every PNG flavour to RGBA8 and handles libpng's longjmp inside
  // libpng itself, so no setjmp is needed here.
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, png.data(), png.size())) {
    throw PngError(std::string("not a valid PNG: ") + image.message);
  }
  image.format = PNG_FORMAT_RGBA;

  DecodedImage decoded;
  decoded.width = image.width;
  decoded.height = image.height;
  try {
    decoded.rgba.resize(size_t(image.width) * image.height * 4);
  } catch (...) {
    png_image_free(&image);
    throw;
  }
  if (!png_image_finish_read(&image, nullptr, decoded.rgba.data(), 0, nullptr)) {
    std::string message = image.message;
    png_image_free(&image);
    throw PngError("not a valid PNG: " + message);
  }
  return decoded;
}

}  // namespace myriad::encode
