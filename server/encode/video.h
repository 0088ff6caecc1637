// Video encoding of rendered frames for GET .../stream?codec= (libvpx: VP8 and VP9; OpenH264:
// H.264, in h264.cpp), and the matching decoder that tests and the stream benchmark use to look
// at what a client would see.
// Plain CPU code: an encoder belongs to one video channel (service/shared_frames.h: the streams
// of a session asking for the same video) and runs on the HTTP worker of whichever of its streams
// makes the frame, one at a time (libvpx adds its own threads); never on the render thread.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace myriad::encode {

// libvpx (or OpenH264) refused a configuration or failed to encode/decode.
class VideoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// In the order of protocol::kVideoCodecs, which names them.
enum class VideoCodec { Vp8, Vp9, H264 };

class H264Encoder;
class H264Decoder;

struct VideoSettings {
  VideoCodec codec = VideoCodec::Vp8;
  uint32_t width = 0;   // 2..16,383 (libvpx's limit); H264: even, at most 36,864 macroblocks
  uint32_t height = 0;  // 2..16,383
  uint32_t fps = 30;    // the expected rate: sizes the rate control's buffer and key frame spacing
  uint32_t bitrateKbps = 4000;  // the target bitrate (constant bitrate rate control)
  uint32_t threads = 4;         // encoder threads (H264: as many slices), 1..16
  // The speed/quality trade: libvpx's cpu-used (VP8 -16..16, VP9's realtime 5..9), OpenH264's
  // complexity mode (0 low, 1 medium, 2 high). kDefaultSpeed: the codec's chosen default
  // (video.cpp says how it was chosen: measured by myriad-video-settings-bench).
  static constexpr int kDefaultSpeed = -100;
  int speed = kDefaultSpeed;
  // Frames between automatic key frames (key frames also come on request); 0: fps * 10.
  uint32_t keyInterval = 0;
  // The rate control's buffer in ms (libvpx rc_buf_sz; OpenH264 has none to set): how far a
  // frame's size may run ahead of the bitrate, and so how much a big frame can delay the next
  // ones on a link at the cap. 0: the default (video.cpp).
  uint32_t bufferMs = 0;
};

struct VideoPacket {
  // One frame of the codec's bitstream (VP9: one superframe; H264: Annex B NAL units with start
  // codes, SPS and PPS first in a key frame's).
  std::vector<uint8_t> data;
  bool key = false;           // a key frame: decodable without anything before it
};

// One realtime encoder: no B-frames, no look-ahead (each frame's packet comes out of the call
// that took it), constant bitrate with a 1 s buffer, no dropped frames, BT.601 studio-range YUV
// 4:2:0. The first frame is a key frame, and so is every frame asked for with forceKey.
class VideoEncoder {
 public:
  // Throws std::invalid_argument for sizes, fps, bitrate or threads out of range and VideoError
  // when libvpx refuses the configuration.
  explicit VideoEncoder(const VideoSettings& settings);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  // Encodes tightly packed RGBA8 rows, top row first (alpha ignored), taken `timestampMs` after
  // the stream began (non-decreasing). Throws std::invalid_argument when rgba.size() is not
  // width * height * 4 and VideoError when libvpx fails.
  VideoPacket encode(std::span<const uint8_t> rgba, uint64_t timestampMs, bool forceKey);

  // A new target bitrate (1..1,000,000 kbit/s) for the frames encoded from now on, without a key
  // frame (the rate control's configuration changes in place); settings().bitrateKbps follows.
  // Throws std::invalid_argument out of range and VideoError when libvpx refuses it.
  void setBitrate(uint32_t kbps);

  const VideoSettings& settings() const { return settings_; }

 private:
  struct Impl;
  VideoSettings settings_;
  std::unique_ptr<Impl> impl_;           // libvpx (VP8, VP9)
  std::unique_ptr<H264Encoder> h264_;    // OpenH264 (H264)
};

// Decodes the packets of one stream back to RGBA8 (alpha 255) with the inverse of the encoder's
// colour conversion.
class VideoDecoder {
 public:
  explicit VideoDecoder(VideoCodec codec);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  struct Picture {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> rgba;
  };
  // The picture of one packet. Throws VideoError when the packet does not decode (or shows
  // nothing, which a packet of this encoder never does).
  Picture decode(std::span<const uint8_t> packet);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<H264Decoder> h264_;
};

// protocol::kVideoCodecs' name of `codec` ("vp8", "vp9", "h264"), and the codec string WebCodecs'
// VideoDecoder.configure (and Media Source Extensions' codecs=) takes for this encoder's output
// at that size, rate and bitrate: protocol::kWebCodecsCodecs' for VP8 and VP9; for H264
// "avc1.42C0LL", Constrained Baseline at level LL (hex level_idc: h264Level's, which the encoder
// writes).
std::string_view videoCodecName(VideoCodec codec);
std::string webCodecsName(VideoCodec codec, uint32_t width, uint32_t height, uint32_t fps,
                          uint32_t kbps);

// The smallest H.264 level (level_idc: 10 = 1.0 ... 52 = 5.2) whose frame size (MaxFS) holds
// width x height, whose macroblock rate (MaxMBPS) holds it at fps and whose bitrate (MaxBR, which
// OpenH264 holds the target to) holds kbps; 0 when no level up to 5.2 holds the frame size (more
// than 36,864 macroblocks: 4096x2304). A rate above 5.2's still gets 5.2 (decoders play it; only
// the rate is out of the level's bound).
uint8_t h264Level(uint32_t width, uint32_t height, uint32_t fps, uint32_t kbps);

// The colour conversions, exposed for tests: BT.601 studio range, chroma the mean of each 2x2
// block (odd sizes: the last row/column alone). Planes are tightly packed: Y width*height, U and V
// ((width+1)/2)*((height+1)/2) each.
void rgbaToI420(std::span<const uint8_t> rgba, uint32_t width, uint32_t height, uint8_t* y,
                size_t yStride, uint8_t* u, size_t uStride, uint8_t* v, size_t vStride);
void i420ToRgba(const uint8_t* y, size_t yStride, const uint8_t* u, size_t uStride,
                const uint8_t* v, size_t vStride, uint32_t width, uint32_t height, uint8_t* rgba);

// Peak signal-to-noise ratio in dB of two RGBA8 pictures of one size over R, G and B (alpha
// ignored); +infinity when they are equal. Throws std::invalid_argument on a size mismatch.
double psnrRgb(std::span<const uint8_t> a, std::span<const uint8_t> b);

}  // namespace myriad::encode
