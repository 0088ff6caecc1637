#include "encode/jpeg.h"

#include <memory>
#include <string>

#include <turbojpeg.h>

namespace myriad::encode {

namespace {

// JPEG stores sizes in 16 bits.
constexpr uint32_t kMaxJpegDimension = 65535;
constexpr int kFullChromaQuality = 90;

struct HandleDeleter {
  void operator()(void* handle) const { tjDestroy(handle); }
};
struct BufferDeleter {
  void operator()(unsigned char* buffer) const { tjFree(buffer); }
};

}  // namespace

std::vector<uint8_t> encodeJpeg(std::span<const uint8_t> rgba, uint32_t width, uint32_t height,
                                int quality) {
  if (width == 0 || height == 0 || width > kMaxJpegDimension || height > kMaxJpegDimension) {
    throw std::invalid_argument("JPEG size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is outside 1.." + std::to_string(kMaxJpegDimension));
  }
  if (rgba.size() != size_t(width) * height * 4) {
    throw std::invalid_argument("RGBA data of " + std::to_string(rgba.size()) + " bytes for a " +
                                std::to_string(width) + "x" + std::to_string(height) + " image");
  }
  if (quality < 1 || quality > 100) {
    throw std::invalid_argument("JPEG quality " + std::to_string(quality) + " is outside 1..100");
  }
  // A handle per call: cheap next to the encoding, and no state shared between worker threads.
  std::unique_ptr<void, HandleDeleter> handle(tjInitCompress());
  if (!handle) throw JpegError(std::string("tjInitCompress failed: ") + tjGetErrorStr2(nullptr));
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const int subsampling = quality >= kFullChromaQuality ? TJSAMP_444 : TJSAMP_420;
  int result = tjCompress2(handle.get(), rgba.data(), int(width), 0, int(height), TJPF_RGBA, &out,
                           &size, subsampling, quality, 0);
  std::unique_ptr<unsigned char, BufferDeleter> owned(out);
  if (result != 0) {
    throw JpegError(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle.get()));
  }
  return std::vector<uint8_t>(out, out + size);
}

}  // namespace myriad::encode
