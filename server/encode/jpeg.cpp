#include "encode/jpeg.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <iterator>
#include <memory>
#include <string>
#include <thread>

#include <turbojpeg.h>

namespace myriad::encode {

namespace {

// JPEG stores sizes in 16 bits.
constexpr uint32_t kMaxJpegDimension = 65535;
constexpr int kFullChromaQuality = 90;
// Images of at least this many pixels are encoded in strips on up to kMaxStripThreads threads by
// default (one 1280x720 frame and up; smaller ones take a few milliseconds on one).
constexpr uint64_t kParallelPixels = 1280 * 720;
constexpr unsigned kMaxStripThreads = 8;
// DRI stores the restart interval (in MCUs) in 16 bits.
constexpr uint32_t kMaxRestartInterval = 65535;

struct HandleDeleter {
  void operator()(void* handle) const { tjDestroy(handle); }
};
struct BufferDeleter {
  void operator()(unsigned char* buffer) const { tjFree(buffer); }
};

}  // namespace

namespace {

// Takes over a buffer tjCompress* allocated; throws with the handle's message when it failed.
std::vector<uint8_t> compressed(void* handle, int result, unsigned char* out, unsigned long size) {
  std::unique_ptr<unsigned char, BufferDeleter> owned(out);
  if (result != 0) {
    throw JpegError(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle));
  }
  return std::vector<uint8_t>(out, out + size);
}

std::unique_ptr<void, HandleDeleter> compressor() {
  // A handle per call: cheap next to the encoding, and no state shared between threads.
  std::unique_ptr<void, HandleDeleter> handle(tjInitCompress());
  if (!handle) throw JpegError(std::string("tjInitCompress failed: ") + tjGetErrorStr2(nullptr));
  return handle;
}

// One baseline JPEG of `rows` rows starting at `firstRow` (the whole image: 0, height).
std::vector<uint8_t> compressRows(std::span<const uint8_t> rgba, uint32_t width, uint32_t firstRow,
                                  uint32_t rows, int subsampling, int quality) {
  std::unique_ptr<void, HandleDeleter> handle = compressor();
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const unsigned char* first = rgba.data() + size_t(firstRow) * width * 4;
  int result = tjCompress2(handle.get(), first, int(width), 0, int(rows), TJPF_RGBA, &out, &size,
                           subsampling, quality, 0);
  return compressed(handle.get(), result, out, size);
}

// YCbCr 4:2:0 planes.
struct Planes {
  std::span<const uint8_t> y, cb, cr;
  uint32_t yStride = 0, chromaStride = 0;
};

// The same from planes: `firstRow` is even (strips are whole MCU rows of 16).
std::vector<uint8_t> compressPlaneRows(const Planes& p, uint32_t width, uint32_t firstRow,
                                       uint32_t rows, int quality) {
  std::unique_ptr<void, HandleDeleter> handle = compressor();
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const unsigned char* planes[3] = {p.y.data() + size_t(firstRow) * p.yStride,
                                    p.cb.data() + size_t(firstRow / 2) * p.chromaStride,
                                    p.cr.data() + size_t(firstRow / 2) * p.chromaStride};
  const int strides[3] = {int(p.yStride), int(p.chromaStride), int(p.chromaStride)};
  int result = tjCompressFromYUVPlanes(handle.get(), planes, int(width), strides, int(rows),
                                       TJSAMP_420, &out, &size, quality, 0);
  return compressed(handle.get(), result, out, size);
}

// Where a baseline JPEG's marker `code` starts (its 0xFF), walking the segments from SOI up to
// and including SOS; npos when absent.
size_t findMarker(const std::vector<uint8_t>& jpeg, uint8_t code) {
  size_t at = 2;  // after SOI
  while (at + 4 <= jpeg.size() && jpeg[at] == 0xFF) {
    const uint8_t marker = jpeg[at + 1];
    if (marker == code) return at;
    if (marker == 0xDA) return std::string::npos;  // SOS: the header ends here
    at += 2 + ((size_t(jpeg[at + 2]) << 8) | jpeg[at + 3]);
  }
  return std::string::npos;
}

// The entropy-coded data of a JPEG from tjCompress2: after the SOS header, before EOI.
std::span<const uint8_t> scanData(const std::vector<uint8_t>& jpeg) {
  const size_t sos = findMarker(jpeg, 0xDA);
  if (sos == std::string::npos || jpeg.size() < sos + 4 || jpeg[jpeg.size() - 1] != 0xD9) {
    throw JpegError("an encoded strip has no scan");
  }
  const size_t begin = sos + 2 + ((size_t(jpeg[sos + 2]) << 8) | jpeg[sos + 3]);
  return std::span<const uint8_t>(jpeg).subspan(begin, jpeg.size() - 2 - begin);
}

void checkJpegArguments(uint32_t width, uint32_t height, int quality) {
  if (width == 0 || height == 0 || width > kMaxJpegDimension || height > kMaxJpegDimension) {
    throw std::invalid_argument("JPEG size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is outside 1.." + std::to_string(kMaxJpegDimension));
  }
  if (quality < 1 || quality > 100) {
    throw std::invalid_argument("JPEG quality " + std::to_string(quality) + " is outside 1..100");
  }
}

// The picture encoded by `compress(firstRow, rows)` (rows a whole number of MCU rows but for
// the last strip): whole when small or on one thread, else in strips joined with restart markers.
template <class Compress>
std::vector<uint8_t> encodeInStrips(uint32_t width, uint32_t height, int subsampling,
                                    unsigned threads, Compress compress) {
  // Measured on the 2-core container while both cores were busy: strips were slower (4K: 112
  // against 93 ms), so a machine of 2 or 3 cores encodes on one thread.
  if (threads == 0) threads = std::min(kMaxStripThreads, std::thread::hardware_concurrency() / 2);
  if (uint64_t(width) * height < kParallelPixels || threads < 2) {
    return compress(0, height);
  }
  // In parallel: strips of whole MCU rows, each encoded as a JPEG of its own by its own thread,
  // then joined into one baseline JPEG with restart markers between them. A restart resets the
  // DC predictions, which is what starting a new image does, and the encoder pads each strip's
  // scan to a byte as it does before a restart marker: the decoded pixels are those of a
  // single-threaded encoding (encode CTest). Every strip but the last holds exactly the restart
  // interval's MCUs.
  const uint32_t mcuWidth = subsampling == TJSAMP_420 ? 16 : 8;
  const uint32_t mcuHeight = subsampling == TJSAMP_420 ? 16 : 8;
  const uint32_t mcusPerRow = (width + mcuWidth - 1) / mcuWidth;
  const uint32_t mcuRows = (height + mcuHeight - 1) / mcuHeight;
  uint32_t rowsPerStrip = (mcuRows + threads - 1) / threads;
  rowsPerStrip = std::max(1u, std::min(rowsPerStrip, kMaxRestartInterval / mcusPerRow));
  const uint32_t strips = (mcuRows + rowsPerStrip - 1) / rowsPerStrip;
  if (strips < 2) return compress(0, height);

  std::vector<std::vector<uint8_t>> encoded(strips);
  std::vector<std::exception_ptr> failures(strips);
  std::atomic<uint32_t> next{0};
  auto work = [&] {
    for (uint32_t i = next++; i < strips; i = next++) {
      const uint32_t first = i * rowsPerStrip * mcuHeight;
      const uint32_t rows = std::min(rowsPerStrip * mcuHeight, height - first);
      try {
        encoded[i] = compress(first, rows);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < std::min<unsigned>(threads, strips); ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }

  // The first strip's headers, with the whole height in its frame header and a DRI segment (the
  // restart interval) before its scan; then each scan, RSTn between them; then EOI.
  const std::vector<uint8_t>& head = encoded[0];
  const size_t sof = findMarker(head, 0xC0);
  const size_t sos = findMarker(head, 0xDA);
  if (sof == std::string::npos || sos == std::string::npos) {
    throw JpegError("the first encoded strip is not a baseline JPEG");
  }
  size_t total = head.size() + 6;
  for (uint32_t i = 1; i < strips; ++i) total += encoded[i].size() + 2;
  std::vector<uint8_t> out;
  out.reserve(total);
  out.insert(out.end(), head.begin(), head.begin() + std::ptrdiff_t(sos));
  out[sof + 5] = uint8_t(height >> 8);  // SOF: FF C0, length, precision, height, width, ...
  out[sof + 6] = uint8_t(height & 0xFF);
  const uint32_t interval = mcusPerRow * rowsPerStrip;
  const uint8_t dri[] = {0xFF, 0xDD, 0x00, 0x04, uint8_t(interval >> 8), uint8_t(interval & 0xFF)};
  out.insert(out.end(), std::begin(dri), std::end(dri));
  const std::span<const uint8_t> firstScan = scanData(head);
  out.insert(out.end(), head.begin() + std::ptrdiff_t(sos), head.begin() + std::ptrdiff_t(firstScan.data() - head.data()));
  out.insert(out.end(), firstScan.begin(), firstScan.end());
  for (uint32_t i = 1; i < strips; ++i) {
    out.push_back(0xFF);
    out.push_back(uint8_t(0xD0 + (i - 1) % 8));  // RST0..RST7, cycling
    const std::span<const uint8_t> scan = scanData(encoded[i]);
    out.insert(out.end(), scan.begin(), scan.end());
  }
  out.push_back(0xFF);
  out.push_back(0xD9);
  return out;
}

}  // namespace

bool jpegSubsamplesChroma(int quality) { return quality < kFullChromaQuality; }

std::vector<uint8_t> encodeJpeg(std::span<const uint8_t> rgba, uint32_t width, uint32_t height,
                                int quality, unsigned threads) {
  checkJpegArguments(width, height, quality);
  if (rgba.size() != size_t(width) * height * 4) {
    throw std::invalid_argument("RGBA data of " + std::to_string(rgba.size()) + " bytes for a " +
                                std::to_string(width) + "x" + std::to_string(height) + " image");
  }
  const int subsampling = jpegSubsamplesChroma(quality) ? TJSAMP_420 : TJSAMP_444;
  return encodeInStrips(width, height, subsampling, threads, [&](uint32_t first, uint32_t rows) {
    return compressRows(rgba, width, first, rows, subsampling, quality);
  });
}

std::vector<uint8_t> encodeJpegYuv420(std::span<const uint8_t> y, std::span<const uint8_t> cb,
                                      std::span<const uint8_t> cr, uint32_t width, uint32_t height,
                                      uint32_t yStride, uint32_t chromaStride, int quality,
                                      unsigned threads) {
  checkJpegArguments(width, height, quality);
  const uint32_t chromaWidth = (width + 1) / 2;
  const uint32_t chromaRows = (height + 1) / 2;
  if (yStride < width || chromaStride < chromaWidth ||
      y.size() < size_t(yStride) * (height - 1) + width ||
      cb.size() < size_t(chromaStride) * (chromaRows - 1) + chromaWidth ||
      cr.size() < size_t(chromaStride) * (chromaRows - 1) + chromaWidth) {
    throw std::invalid_argument("YCbCr 4:2:0 planes of " + std::to_string(y.size()) + ", " +
                                std::to_string(cb.size()) + " and " + std::to_string(cr.size()) +
                                " bytes (strides " + std::to_string(yStride) + ", " +
                                std::to_string(chromaStride) + ") for a " + std::to_string(width) +
                                "x" + std::to_string(height) + " image");
  }
  const Planes planes{y, cb, cr, yStride, chromaStride};
  return encodeInStrips(width, height, TJSAMP_420, threads, [&](uint32_t first, uint32_t rows) {
    return compressPlaneRows(planes, width, first, rows, quality);
  });
}

}  // namespace myriad::encode
