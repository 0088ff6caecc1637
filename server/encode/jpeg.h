// JPEG encoding of rendered frames (streams and format=jpeg). Plain CPU code: runs on the HTTP
// worker threads, never on the render thread.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace myriad::encode {

// libturbojpeg reported an error (out of memory, an internal failure).
class JpegError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Encodes tightly packed RGBA8 rows, top row first (alpha ignored), as a baseline JPEG at
// `quality` 1..100. Chroma is subsampled 4:2:0 below quality 90 and kept whole (4:4:4) from 90 up,
// where the asker wants fidelity more than size. Images of 1280x720 pixels and more are encoded in
// strips of whole MCU rows on `threads` threads (0: half the machine's cores, at most 8, leaving
// the rest to the renderer and the other workers; 1: one thread) and joined with restart markers:
// the decoded pixels are the same as one encoding's.
// Throws std::invalid_argument when rgba.size() != width * height * 4, a size is 0 or above
// JPEG's 65,535, or quality is outside 1..100; JpegError when libturbojpeg fails.
std::vector<uint8_t> encodeJpeg(std::span<const uint8_t> rgba, uint32_t width, uint32_t height,
                                int quality, unsigned threads = 0);

// Whether encodeJpeg subsamples chroma (4:2:0) at `quality`: below 90.
bool jpegSubsamplesChroma(int quality);

// YCbCr 4:2:0 planes (JFIF's BT.601 full-range conversion already done, chroma already
// subsampled: e.g. by the GPU) encoded as encodeJpeg would encode the picture they came from,
// without libjpeg's colour conversion and downsampling: `y` holds `height` rows of `yStride`
// bytes (at least `width`), `cb` and `cr` (height + 1) / 2 rows of `chromaStride` bytes (at least
// (width + 1) / 2). In strips on `threads` threads as encodeJpeg. Throws std::invalid_argument
// when a plane is too small for the sizes or strides, a size is 0 or above 65,535, or quality is
// outside 1..100; JpegError when libturbojpeg fails.
std::vector<uint8_t> encodeJpegYuv420(std::span<const uint8_t> y, std::span<const uint8_t> cb,
                                      std::span<const uint8_t> cr, uint32_t width, uint32_t height,
                                      uint32_t yStride, uint32_t chromaStride, int quality,
                                      unsigned threads = 0);

}  // namespace myriad::encode
