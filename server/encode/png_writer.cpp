#include "encode/png_writer.h"

#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <exception>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <stdexcept>
#include <thread>

namespace myriad::encode {
namespace {

// PNG stores sizes as 31-bit unsigned integers.
constexpr uint32_t kMaxPngDimension = 0x7fffffffu;

struct CompressorDeleter {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};

// One compressor per level and worker thread: a compressor holds its hash tables (about 0.5 MB
// at level 1, more above), made once instead of per frame, and is not thread-safe.
libdeflate_compressor* compressorFor(int level) {
  thread_local std::array<std::unique_ptr<libdeflate_compressor, CompressorDeleter>, 13> cache;
  auto& slot = cache.at(static_cast<size_t>(level));
  if (!slot) {
    slot.reset(libdeflate_alloc_compressor(level));
    if (!slot) throw std::bad_alloc();
  }
  return slot.get();
}

void putU32(std::vector<uint8_t>& out, uint32_t v) {
  out.push_back(uint8_t(v >> 24));
  out.push_back(uint8_t(v >> 16));
  out.push_back(uint8_t(v >> 8));
  out.push_back(uint8_t(v));
}

// A chunk whose data is already at the end of `out`, after its 8-byte header at `start`: fills in
// the length and appends the CRC of type and data.
void closeChunk(std::vector<uint8_t>& out, size_t start) {
  const uint32_t length = uint32_t(out.size() - start - 8);
  out[start] = uint8_t(length >> 24);
  out[start + 1] = uint8_t(length >> 16);
  out[start + 2] = uint8_t(length >> 8);
  out[start + 3] = uint8_t(length);
  const uint32_t crc = libdeflate_crc32(0, out.data() + start + 4, length + 4);
  putU32(out, crc);
}

size_t openChunk(std::vector<uint8_t>& out, const char type[4]) {
  const size_t start = out.size();
  putU32(out, 0);
  out.insert(out.end(), type, type + 4);
  return start;
}

uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return uint8_t(a);
  return pb <= pc ? uint8_t(b) : uint8_t(c);
}

// One row filtered into `out` (its filter byte first). `prior` is the row above as stored
// (unfiltered), or null for the first row (PNG treats it as zeros).
void filterRow(PngFilter filter, const uint8_t* row, const uint8_t* prior, size_t stride,
               size_t bpp, uint8_t* out) {
  *out++ = uint8_t(filter);
  switch (filter) {
    case PngFilter::None:
      std::memcpy(out, row, stride);
      return;
    case PngFilter::Sub:
      for (size_t i = 0; i < bpp && i < stride; ++i) out[i] = row[i];
      for (size_t i = bpp; i < stride; ++i) out[i] = uint8_t(row[i] - row[i - bpp]);
      return;
    case PngFilter::Up:
      if (!prior) {
        std::memcpy(out, row, stride);
        return;
      }
      for (size_t i = 0; i < stride; ++i) out[i] = uint8_t(row[i] - prior[i]);
      return;
    case PngFilter::Average:
      for (size_t i = 0; i < stride; ++i) {
        const int left = i >= bpp ? row[i - bpp] : 0;
        const int up = prior ? prior[i] : 0;
        out[i] = uint8_t(row[i] - ((left + up) >> 1));
      }
      return;
    case PngFilter::Paeth:
      for (size_t i = 0; i < stride; ++i) {
        const int left = i >= bpp ? row[i - bpp] : 0;
        const int up = prior ? prior[i] : 0;
        const int upLeft = i >= bpp && prior ? prior[i - bpp] : 0;
        out[i] = uint8_t(row[i] - paeth(left, up, upLeft));
      }
      return;
  }
}

// The stored bytes of row y (RGBA8 to RGB8 when `dropAlpha`, 16-bit samples big-endian) in
// `scratch`, or the pixels themselves when they are stored as given.
const uint8_t* storedRow(std::span<const uint8_t> pixels, PngPixels kind, bool dropAlpha,
                         uint32_t width, uint32_t y, std::vector<uint8_t>& scratch) {
  const size_t inStride = size_t(width) * (kind == PngPixels::Rgba8 ? 4 : kind == PngPixels::Rgb8 ? 3 : 2);
  const uint8_t* row = pixels.data() + inStride * y;
  if (kind == PngPixels::Grey16) {
    scratch.resize(inStride);
    for (size_t i = 0; i < inStride; i += 2) {
      uint16_t v;
      std::memcpy(&v, row + i, 2);
      scratch[i] = uint8_t(v >> 8);
      scratch[i + 1] = uint8_t(v);
    }
    return scratch.data();
  }
  if (dropAlpha) {
    scratch.resize(size_t(width) * 3);
    for (uint32_t x = 0; x < width; ++x) {
      scratch[x * 3] = row[x * 4];
      scratch[x * 3 + 1] = row[x * 4 + 1];
      scratch[x * 3 + 2] = row[x * 4 + 2];
    }
    return scratch.data();
  }
  return row;
}

// Rows [first, first + count) filtered into `out` (stride + 1 bytes a row).
void filterRows(std::span<const uint8_t> pixels, PngPixels kind, bool dropAlpha, uint32_t width,
                uint32_t first, uint32_t count, size_t stride, size_t bpp, PngFilter filter,
                uint8_t* out) {
  std::vector<uint8_t> current, prior;
  const uint8_t* priorRow = nullptr;
  if (first > 0 && filter != PngFilter::None && filter != PngFilter::Sub) {
    priorRow = storedRow(pixels, kind, dropAlpha, width, first - 1, prior);
  }
  for (uint32_t y = first; y < first + count; ++y) {
    const uint8_t* row = storedRow(pixels, kind, dropAlpha, width, y, current);
    filterRow(filter, row, priorRow, stride, bpp, out + (stride + 1) * (y - first));
    if (row == current.data()) {
      current.swap(prior);
      priorRow = prior.data();
    } else {
      priorRow = row;
    }
  }
}

// `count` strips of `rows` rows each (the last fewer) run by `threads` threads, `task(strip)`.
template <class Task>
void inParallel(uint32_t count, unsigned threads, Task task) {
  std::vector<std::exception_ptr> failures(count);
  std::atomic<uint32_t> next{0};
  auto work = [&] {
    for (uint32_t i = next++; i < count; i = next++) {
      try {
        task(i);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < std::min<unsigned>(threads, count); ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
}

// Raw deflate of `data` by zlib; ends on a byte boundary with a sync flush (not the last strip)
// or the final block (the last), so that strips join into one stream.
std::vector<uint8_t> deflateStrip(std::span<const uint8_t> data, int level, bool last) {
  z_stream z{};
  if (deflateInit2(&z, std::min(level, 9), Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw std::bad_alloc();
  }
  std::vector<uint8_t> out(deflateBound(&z, data.size()) + 16);
  z.next_in = const_cast<Bytef*>(data.data());
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int result = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
  const size_t written = out.size() - z.avail_out;
  deflateEnd(&z);
  if ((last && result != Z_STREAM_END) || (!last && result != Z_OK) || z.avail_in != 0) {
    throw std::runtime_error("writePng: zlib could not deflate a strip");
  }
  out.resize(written);
  return out;
}

unsigned defaultThreads() {
  // As the JPEG strips (encode/jpeg.cpp): half the cores, at most 8; one on 2-3 cores, where
  // strips measured slower while the cores were busy.
  return std::min(8u, std::thread::hardware_concurrency() / 2);
}

}  // namespace

std::vector<uint8_t> writePng(uint32_t width, uint32_t height, PngPixels kind,
                              std::span<const uint8_t> pixels, const PngSettings& settings,
                              const PngText& text) {
  if (width == 0 || height == 0 || width > kMaxPngDimension || height > kMaxPngDimension) {
    throw std::invalid_argument("writePng: image size " + std::to_string(width) + "x" +
                                std::to_string(height) + " is outside PNG's 1..2^31-1 range");
  }
  if (settings.level < 0 || settings.level > 12) {
    throw std::invalid_argument("writePng: libdeflate level " + std::to_string(settings.level) +
                                " is outside 0..12");
  }
  const size_t inBpp = kind == PngPixels::Rgba8 ? 4 : kind == PngPixels::Rgb8 ? 3 : 2;
  if (pixels.size() != size_t(width) * inBpp * height) {
    throw std::invalid_argument("writePng: " + std::to_string(pixels.size()) +
                                " bytes of pixels for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image of " + std::to_string(inBpp) +
                                " bytes a pixel");
  }
  bool dropAlpha = kind == PngPixels::Rgba8;
  for (size_t i = 3; dropAlpha && i < pixels.size(); i += 4) dropAlpha = pixels[i] == 255;
  const size_t bpp = dropAlpha ? 3 : inBpp;
  const size_t stride = size_t(width) * bpp;
  const size_t filteredBytes = (stride + 1) * height;

  const unsigned threads = settings.threads == 0 ? defaultThreads() : settings.threads;
  const bool parallel = threads >= 2 && uint64_t(width) * height >= kParallelPngPixels &&
                        height >= 2 * threads;

  std::vector<uint8_t> filtered(filteredBytes);
  // Strips: in parallel, each thread filters and deflates its own rows.
  const uint32_t strips = parallel ? threads * 2 : 1;
  const uint32_t rowsPerStrip = (height + strips - 1) / strips;
  const uint32_t stripCount = (height + rowsPerStrip - 1) / rowsPerStrip;
  std::vector<std::vector<uint8_t>> deflated(parallel ? stripCount : 0);
  std::vector<uint32_t> adlers(parallel ? stripCount : 0);
  auto stripBytes = [&](uint32_t i) {
    const uint32_t first = i * rowsPerStrip;
    const uint32_t rows = std::min(rowsPerStrip, height - first);
    return std::span<const uint8_t>(filtered.data() + (stride + 1) * first, (stride + 1) * rows);
  };
  if (parallel) {
    inParallel(stripCount, threads, [&](uint32_t i) {
      const uint32_t first = i * rowsPerStrip;
      const uint32_t rows = std::min(rowsPerStrip, height - first);
      filterRows(pixels, kind, dropAlpha, width, first, rows, stride, bpp, settings.filter,
                 filtered.data() + (stride + 1) * first);
      const std::span<const uint8_t> bytes = stripBytes(i);
      deflated[i] = deflateStrip(bytes, settings.level, i + 1 == stripCount);
      adlers[i] = static_cast<uint32_t>(adler32(1, bytes.data(), static_cast<uInt>(bytes.size())));
    });
  } else {
    filterRows(pixels, kind, dropAlpha, width, 0, height, stride, bpp, settings.filter,
               filtered.data());
  }

  libdeflate_compressor* compressor = parallel ? nullptr : compressorFor(settings.level);
  size_t bound = 0;
  if (parallel) {
    bound = 6;  // zlib header and Adler-32
    for (const auto& strip : deflated) bound += strip.size();
  } else {
    bound = libdeflate_zlib_compress_bound(compressor, filtered.size());
  }

  std::vector<uint8_t> out;
  size_t textBytes = 0;
  for (const auto& [keyword, value] : text) textBytes += 13 + keyword.size() + value.size();
  out.reserve(8 + 25 + textBytes + 12 + bound + 12);
  static constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  for (uint8_t byte : kSignature) out.push_back(byte);

  size_t chunk = openChunk(out, "IHDR");
  putU32(out, width);
  putU32(out, height);
  out.push_back(kind == PngPixels::Grey16 ? 16 : 8);  // bit depth
  out.push_back(kind == PngPixels::Grey16 ? 0 : bpp == 4 ? 6 : 2);  // grey, RGBA or RGB
  out.push_back(0);  // compression: deflate
  out.push_back(0);  // filter method: adaptive (per-row filter byte)
  out.push_back(0);  // no interlace
  closeChunk(out, chunk);

  for (const auto& [keyword, value] : text) {
    if (keyword.empty() || keyword.size() > 79) {
      throw std::invalid_argument("writePng: a tEXt keyword has 1 to 79 characters");
    }
    chunk = openChunk(out, "tEXt");
    out.insert(out.end(), keyword.begin(), keyword.end());
    out.push_back(0);
    out.insert(out.end(), value.begin(), value.end());
    closeChunk(out, chunk);
  }

  chunk = openChunk(out, "IDAT");
  if (parallel) {
    // zlib header: deflate, 32 KiB window, no dictionary, check bits (RFC 1950).
    out.push_back(0x78);
    out.push_back(0x01);
    uint32_t adler = 1;
    for (uint32_t i = 0; i < stripCount; ++i) {
      out.insert(out.end(), deflated[i].begin(), deflated[i].end());
      adler = static_cast<uint32_t>(adler32_combine(adler, adlers[i], static_cast<z_off_t>(stripBytes(i).size())));
    }
    putU32(out, adler);
  } else {
    const size_t dataStart = out.size();
    out.resize(dataStart + bound);
    const size_t written = libdeflate_zlib_compress(compressor, filtered.data(), filtered.size(),
                                                    out.data() + dataStart, bound);
    if (written == 0) throw std::runtime_error("writePng: libdeflate ran out of output space");
    out.resize(dataStart + written);
  }
  closeChunk(out, chunk);

  chunk = openChunk(out, "IEND");
  closeChunk(out, chunk);
  return out;
}

}  // namespace myriad::encode
