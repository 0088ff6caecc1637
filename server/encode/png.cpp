#include "encode/png.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <limits>
#include <new>
#include <string>

namespace myriad::encode {
namespace {

// Frames are encoded per request on a worker thread, so encoder CPU time is response latency.
// Measured on a 1280x720 `final` frame of the built-in scene (libpng 1.6.39, -O2, one core of the
// 2-core dev machine, SUB filter): zlib level 1 gives 694 KB in 28 ms, level 3 642 KB in 56 ms,
// level 6 511 KB in 149 ms. Level 3 buys 7% over level 1 for a cost still small beside the frame's
// render time (0.6 s on lavapipe, debug build); level 6's further 20% is not worth nearly 3x the
// time on loopback or a LAN, where the bytes cost less than the CPU.
constexpr int kZlibLevel = 3;

// One fixed filter instead of libpng's adaptive choice: in the same measurement SUB alone gave
// the smallest file of every filter set on the final frame (642 KB; adaptive over all five 649 KB
// at 30% more time, since it trial-filters each row five ways), and stayed within 12% of the best
// on normal and depth views. Rendered images are smooth horizontal gradients between hard edges,
// which is what SUB predicts well.
constexpr int kFilters = PNG_FILTER_SUB;

// PNG stores sizes as 31-bit unsigned integers.
constexpr uint32_t kMaxPngDimension = 0x7fffffffu;

struct WriteTarget {
  std::vector<uint8_t>* bytes;
  char error[256];
};

// libpng reports failure by calling this, which must not return: it records the message and
// jumps back to the setjmp in writeImage().
[[noreturn]] void onPngError(png_structp png, png_const_charp message) {
  auto* target = static_cast<WriteTarget*>(png_get_error_ptr(png));
  std::snprintf(target->error, sizeof target->error, "%s", message);
  png_longjmp(png, 1);
}

// Warnings concern ancillary chunks, which we do not write; they are not worth a log line per
// frame.
void onPngWarning(png_structp, png_const_charp) {}

void appendBytes(png_structp png, png_bytep data, size_t length) {
  auto* target = static_cast<WriteTarget*>(png_get_io_ptr(png));
  bool appended = true;
  try {
    target->bytes->insert(target->bytes->end(), data, data + length);
  } catch (const std::bad_alloc&) {
    appended = false;
  }
  // A C++ exception must not unwind through libpng's C frames, so the failure goes back through
  // libpng's own error path instead, outside the catch block.
  if (!appended) png_error(png, "out of memory");
}

// Without a flush callback libpng would fflush() the io pointer as a FILE*.
void flushNothing(png_structp) {}

// Every libpng call that can fail is made here, after setjmp. libpng reports errors by longjmp
// back to this frame, which is only sound because no object with a destructor lives between the
// setjmp and those calls, and no local changed after setjmp is read after the jump.
bool writeImage(png_structp png, png_infop info, uint32_t width, uint32_t height, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, kZlibLevel);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, kFilters);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return true;
}

// Owns the libpng write structures; lives in encodePng(), outside the frames longjmp crosses.
struct PngWriter {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngWriter() { png_destroy_write_struct(&png, &info); }
};

}  // namespace

std::vector<uint8_t> encodePng(uint32_t width, uint32_t height, std::span<const uint8_t> rgba) {
  if (width == 0 || height == 0 || width > kMaxPngDimension || height > kMaxPngDimension) {
    throw std::invalid_argument("encodePng: image size " + std::to_string(width) + "x" +
                                std::to_string(height) + " is outside PNG's 1..2^31-1 range");
  }
  const size_t stride = size_t(width) * 4;
  if (rgba.size() != stride * height) {
    throw std::invalid_argument("encodePng: " + std::to_string(rgba.size()) +
                                " bytes of pixels for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " RGBA8 image");
  }

  // libpng's row pointers are non-const for historical reasons; writing only reads through them.
  std::vector<png_bytep> rows(height);
  for (uint32_t y = 0; y < height; ++y) {
    rows[y] = const_cast<png_bytep>(rgba.data() + stride * y);
  }

  std::vector<uint8_t> bytes;
  // Rendered frames typically compress to a fifth of their raw size or less; one reservation
  // avoids most of the regrowth copies.
  bytes.reserve(rgba.size() / 4 + 1024);
  WriteTarget target{&bytes, {}};

  PngWriter writer;
  writer.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &target, onPngError, onPngWarning);
  if (writer.png == nullptr) throw PngError("PNG encoding failed: out of memory");
  writer.info = png_create_info_struct(writer.png);
  if (writer.info == nullptr) throw PngError("PNG encoding failed: out of memory");
  png_set_write_fn(writer.png, &target, appendBytes, flushNothing);

  if (!writeImage(writer.png, writer.info, width, height, rows.data())) {
    throw PngError(std::string("PNG encoding failed: ") + target.error);
  }
  return bytes;
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
