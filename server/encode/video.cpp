#include "encode/video.h"

#include <vpx/vp8cx.h>
#include <vpx/vp8dx.h>
#include <vpx/vpx_decoder.h>
#include <vpx/vpx_encoder.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "encode/h264.h"
#include "protocol/constants.h"

namespace myriad::encode {
namespace {

constexpr uint32_t kMaxDimension = 16383;
// Defaults of VideoSettings' speed and bufferMs, measured (myriad-video-settings-bench; the
// figures are in docs/ARCHITECTURE.md, "Encoder settings"):
// VP8 speed 10 of 16 (realtime): about half the bits of speed 16 at the same quality for a
// rendered scene, still well below a frame interval at 1080p on 4 threads.
constexpr int kVp8Speed = 10;
// VP9 speed 8 (realtime speeds are 5..9): 6 and 7 gave 0.2-0.3 dB more for the same time at
// 640x360 on 1 thread, 9 the same quality and time; 8 is where the H200 figures were taken.
constexpr int kVp9Speed = 8;
// A 200 ms buffer (it was 1 s): the rate control lets frames run up to the buffer ahead of the
// bitrate, so on a link at the cap a 1 s buffer queued 350-400 ms of frames (median delay at
// 640x360 VP9, 1.5 Mbit/s), 200 ms queues 110 ms, at the same mean PSNR (45.4 against 45.2 dB);
// 100 ms starves the first key frame (32.7 dB against 35.9).
constexpr uint32_t kDefaultBufferMs = 200;

uint8_t clampByte(int value) { return static_cast<uint8_t>(std::clamp(value, 0, 255)); }

std::string vpxMessage(vpx_codec_ctx_t* ctx, const char* what) {
  std::string message = std::string(what) + ": " + vpx_codec_error(ctx);
  if (const char* detail = vpx_codec_error_detail(ctx)) message += std::string(" (") + detail + ")";
  return message;
}

}  // namespace

std::string_view videoCodecName(VideoCodec codec) {
  return protocol::kVideoCodecs[static_cast<size_t>(codec)];
}

std::string webCodecsName(VideoCodec codec, uint32_t width, uint32_t height, uint32_t fps,
                          uint32_t kbps) {
  if (codec != VideoCodec::H264) {
    return std::string(protocol::kWebCodecsCodecs[static_cast<size_t>(codec)]);
  }
  // profile_idc 66, constraint_set0 and set1 (Constrained Baseline), then the level.
  static constexpr char kHex[] = "0123456789ABCDEF";
  const uint8_t level = h264Level(width, height, fps, kbps);
  return std::string(protocol::kWebCodecsH264Prefix) + kHex[level >> 4] + kHex[level & 15];
}

void rgbaToI420(std::span<const uint8_t> rgba, uint32_t width, uint32_t height, uint8_t* y,
                size_t yStride, uint8_t* u, size_t uStride, uint8_t* v, size_t vStride) {
  for (uint32_t row = 0; row < height; ++row) {
    const uint8_t* in = rgba.data() + size_t(row) * width * 4;
    uint8_t* out = y + row * yStride;
    for (uint32_t x = 0; x < width; ++x) {
      const int r = in[x * 4], g = in[x * 4 + 1], b = in[x * 4 + 2];
      out[x] = static_cast<uint8_t>(((66 * r + 129 * g + 25 * b + 128) >> 8) + 16);
    }
  }
  const uint32_t chromaWidth = (width + 1) / 2;
  const uint32_t chromaHeight = (height + 1) / 2;
  for (uint32_t cy = 0; cy < chromaHeight; ++cy) {
    const uint32_t y0 = cy * 2;
    const uint32_t y1 = std::min(y0 + 1, height - 1);
    const uint8_t* row0 = rgba.data() + size_t(y0) * width * 4;
    const uint8_t* row1 = rgba.data() + size_t(y1) * width * 4;
    for (uint32_t cx = 0; cx < chromaWidth; ++cx) {
      const uint32_t x0 = cx * 2;
      const uint32_t x1 = std::min(x0 + 1, width - 1);
      const int r = row0[x0 * 4] + row0[x1 * 4] + row1[x0 * 4] + row1[x1 * 4];
      const int g = row0[x0 * 4 + 1] + row0[x1 * 4 + 1] + row1[x0 * 4 + 1] + row1[x1 * 4 + 1];
      const int b = row0[x0 * 4 + 2] + row0[x1 * 4 + 2] + row1[x0 * 4 + 2] + row1[x1 * 4 + 2];
      // The sums are 4x the mean: scale by 1/1024 instead of 1/256.
      u[cy * uStride + cx] = clampByte(((-38 * r - 74 * g + 112 * b + 512) >> 10) + 128);
      v[cy * vStride + cx] = clampByte(((112 * r - 94 * g - 18 * b + 512) >> 10) + 128);
    }
  }
}

void i420ToRgba(const uint8_t* y, size_t yStride, const uint8_t* u, size_t uStride,
                const uint8_t* v, size_t vStride, uint32_t width, uint32_t height, uint8_t* rgba) {
  for (uint32_t row = 0; row < height; ++row) {
    uint8_t* out = rgba + size_t(row) * width * 4;
    for (uint32_t x = 0; x < width; ++x) {
      const int c = int(y[row * yStride + x]) - 16;
      const int d = int(u[(row / 2) * uStride + x / 2]) - 128;
      const int e = int(v[(row / 2) * vStride + x / 2]) - 128;
      out[x * 4] = clampByte((298 * c + 409 * e + 128) >> 8);
      out[x * 4 + 1] = clampByte((298 * c - 100 * d - 208 * e + 128) >> 8);
      out[x * 4 + 2] = clampByte((298 * c + 516 * d + 128) >> 8);
      out[x * 4 + 3] = 255;
    }
  }
}

double psnrRgb(std::span<const uint8_t> a, std::span<const uint8_t> b) {
  if (a.size() != b.size() || a.size() % 4 != 0 || a.empty()) {
    throw std::invalid_argument("psnrRgb: the pictures differ in size (" +
                                std::to_string(a.size()) + " and " + std::to_string(b.size()) +
                                " bytes)");
  }
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); i += 4) {
    for (size_t c = 0; c < 3; ++c) {
      const double d = double(a[i + c]) - double(b[i + c]);
      sum += d * d;
    }
  }
  const double mse = sum / double(a.size() / 4 * 3);
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

// ---- Encoder.

struct VideoEncoder::Impl {
  vpx_codec_ctx_t codec{};
  vpx_codec_enc_cfg_t config{};  // as initialised, kept for setBitrate
  vpx_image_t image{};
  bool codecOpen = false;
  bool imageAllocated = false;
  uint64_t frames = 0;

  ~Impl() {
    if (codecOpen) vpx_codec_destroy(&codec);
    if (imageAllocated) vpx_img_free(&image);
  }
};

VideoEncoder::VideoEncoder(const VideoSettings& settings)
    : settings_(settings), impl_(std::make_unique<Impl>()) {
  if (settings.width < 2 || settings.height < 2 || settings.width > kMaxDimension ||
      settings.height > kMaxDimension) {
    throw std::invalid_argument("video frames must be 2 to 16383 pixels wide and high, not " +
                                std::to_string(settings.width) + "x" +
                                std::to_string(settings.height));
  }
  if (settings.fps < 1 || settings.fps > 1000) {
    throw std::invalid_argument("video fps must be 1 to 1000");
  }
  if (settings.bitrateKbps < 1 || settings.bitrateKbps > 1000000) {
    throw std::invalid_argument("video bitrate must be 1 to 1,000,000 kbit/s");
  }
  if (settings.threads < 1 || settings.threads > 16) {
    throw std::invalid_argument("video encoder threads must be 1 to 16");
  }
  if (settings.codec == VideoCodec::H264) {
    h264_ = std::make_unique<H264Encoder>(settings);
    return;
  }
  const bool vp8 = settings.codec == VideoCodec::Vp8;
  vpx_codec_iface_t* iface = vp8 ? vpx_codec_vp8_cx() : vpx_codec_vp9_cx();
  vpx_codec_enc_cfg_t cfg{};
  if (vpx_codec_enc_config_default(iface, &cfg, 0) != VPX_CODEC_OK) {
    throw VideoError("libvpx has no default configuration for " +
                     std::string(videoCodecName(settings.codec)));
  }
  cfg.g_w = settings.width;
  cfg.g_h = settings.height;
  cfg.g_timebase = {1, 1000};  // timestamps in milliseconds
  cfg.g_threads = settings.threads;
  cfg.g_lag_in_frames = 0;    // no look-ahead: a frame's packet leaves with it
  cfg.g_error_resilient = 0;  // HTTP delivers every byte in order
  cfg.g_pass = VPX_RC_ONE_PASS;
  cfg.rc_end_usage = VPX_CBR;
  cfg.rc_target_bitrate = settings.bitrateKbps;
  cfg.rc_dropframe_thresh = 0;  // every rendered frame is sent
  cfg.rc_resize_allowed = 0;
  cfg.rc_min_quantizer = 2;
  cfg.rc_max_quantizer = 56;
  cfg.rc_undershoot_pct = 50;
  cfg.rc_overshoot_pct = 50;
  const uint32_t bufferMs = settings.bufferMs != 0 ? settings.bufferMs : kDefaultBufferMs;
  cfg.rc_buf_sz = bufferMs;
  cfg.rc_buf_initial_sz = bufferMs / 2;
  cfg.rc_buf_optimal_sz = bufferMs * 3 / 5;
  // Key frames come on request (a new stream, a decoder that lost its place); one every 10 s
  // besides bounds how long a damaged picture could last.
  cfg.kf_mode = VPX_KF_AUTO;
  cfg.kf_min_dist = 0;
  cfg.kf_max_dist = settings.keyInterval != 0 ? settings.keyInterval : settings.fps * 10;
  if (vpx_codec_enc_init(&impl_->codec, iface, &cfg, 0) != VPX_CODEC_OK) {
    std::string message = vpxMessage(&impl_->codec, "libvpx refused the encoder settings");
    throw VideoError(message);
  }
  impl_->codecOpen = true;
  impl_->config = cfg;
  vpx_codec_ctx_t* ctx = &impl_->codec;
  if (vp8) {
    vpx_codec_control(ctx, VP8E_SET_CPUUSED,
                      settings.speed != VideoSettings::kDefaultSpeed ? settings.speed : kVp8Speed);
    int partitions = 0;
    while ((2u << partitions) <= settings.threads && partitions < 3) ++partitions;
    vpx_codec_control(ctx, VP8E_SET_TOKEN_PARTITIONS, partitions);
    vpx_codec_control(ctx, VP8E_SET_NOISE_SENSITIVITY, 0);
    vpx_codec_control(ctx, VP8E_SET_MAX_INTRA_BITRATE_PCT, 300);
  } else {
    vpx_codec_control(ctx, VP8E_SET_CPUUSED,
                      settings.speed != VideoSettings::kDefaultSpeed ? settings.speed : kVp9Speed);
    vpx_codec_control(ctx, VP9E_SET_ROW_MT, 1);
    int tiles = 0;  // log2 of tile columns: one per thread, each at least 256 pixels wide
    while ((2u << tiles) <= settings.threads && (settings.width >> (tiles + 1)) >= 256) ++tiles;
    vpx_codec_control(ctx, VP9E_SET_TILE_COLUMNS, tiles);
    vpx_codec_control(ctx, VP9E_SET_AQ_MODE, 3);  // cyclic refresh, the realtime mode
    vpx_codec_control(ctx, VP9E_SET_COLOR_SPACE, VPX_CS_BT_601);
    vpx_codec_control(ctx, VP9E_SET_COLOR_RANGE, VPX_CR_STUDIO_RANGE);
    vpx_codec_control(ctx, VP8E_SET_MAX_INTRA_BITRATE_PCT, 300);
    // And a delta frame at most 3 frames' worth of the bitrate, as far as the quantizer range
    // allows: a change of the whole picture (the sun switched on) made 15 KB delta frames at
    // 300 kbit/s (400 ms of the link each, at 320x180; myriad-net-probe behind a cap), so an
    // edit waited for the one before it; capped, 5-6 KB. The change comes at a coarser quality
    // first and sharpens over the next frames.
    vpx_codec_control(ctx, VP9E_SET_MAX_INTER_BITRATE_PCT, 300);
  }
  if (vpx_img_alloc(&impl_->image, VPX_IMG_FMT_I420, settings.width, settings.height, 16) ==
      nullptr) {
    throw VideoError("libvpx could not allocate a " + std::to_string(settings.width) + "x" +
                     std::to_string(settings.height) + " picture");
  }
  impl_->imageAllocated = true;
}

VideoEncoder::~VideoEncoder() = default;

void VideoEncoder::setBitrate(uint32_t kbps) {
  if (kbps < 1 || kbps > 1000000) {
    throw std::invalid_argument("video bitrate must be 1 to 1,000,000 kbit/s");
  }
  if (h264_) {
    h264_->setBitrate(kbps);
    settings_.bitrateKbps = kbps;
    return;
  }
  vpx_codec_enc_cfg_t cfg = impl_->config;
  cfg.rc_target_bitrate = kbps;
  if (vpx_codec_enc_config_set(&impl_->codec, &cfg) != VPX_CODEC_OK) {
    throw VideoError(vpxMessage(&impl_->codec, "libvpx refused the new bitrate"));
  }
  impl_->config = cfg;
  settings_.bitrateKbps = kbps;
}

VideoPacket VideoEncoder::encode(std::span<const uint8_t> rgba, uint64_t timestampMs,
                                 bool forceKey) {
  const size_t expected = size_t(settings_.width) * settings_.height * 4;
  if (rgba.size() != expected) {
    throw std::invalid_argument("video frame has " + std::to_string(rgba.size()) +
                                " bytes, expected " + std::to_string(expected));
  }
  if (h264_) return h264_->encode(rgba, timestampMs, forceKey);
  vpx_image_t& image = impl_->image;
  rgbaToI420(rgba, settings_.width, settings_.height, image.planes[VPX_PLANE_Y],
             image.stride[VPX_PLANE_Y], image.planes[VPX_PLANE_U], image.stride[VPX_PLANE_U],
             image.planes[VPX_PLANE_V], image.stride[VPX_PLANE_V]);
  const vpx_enc_frame_flags_t flags = forceKey ? VPX_EFLAG_FORCE_KF : 0;
  // The duration is the expected interval; the rate control spreads bits by the timestamps.
  const unsigned long duration = std::max<unsigned long>(1, 1000 / settings_.fps);
  if (vpx_codec_encode(&impl_->codec, &image, static_cast<vpx_codec_pts_t>(timestampMs), duration,
                       flags, VPX_DL_REALTIME) != VPX_CODEC_OK) {
    throw VideoError(vpxMessage(&impl_->codec, "libvpx could not encode a frame"));
  }
  VideoPacket packet;
  vpx_codec_iter_t iter = nullptr;
  while (const vpx_codec_cx_pkt_t* pkt = vpx_codec_get_cx_data(&impl_->codec, &iter)) {
    if (pkt->kind != VPX_CODEC_CX_FRAME_PKT) continue;
    const auto* bytes = static_cast<const uint8_t*>(pkt->data.frame.buf);
    packet.data.insert(packet.data.end(), bytes, bytes + pkt->data.frame.sz);
    if (pkt->data.frame.flags & VPX_FRAME_IS_KEY) packet.key = true;
  }
  if (packet.data.empty()) {
    // Frame dropping is off and there is no look-ahead, so every frame has a packet.
    throw VideoError("libvpx returned no packet for frame " + std::to_string(impl_->frames));
  }
  ++impl_->frames;
  return packet;
}

// ---- Decoder.

struct VideoDecoder::Impl {
  vpx_codec_ctx_t codec{};
  bool open = false;
  ~Impl() {
    if (open) vpx_codec_destroy(&codec);
  }
};

VideoDecoder::VideoDecoder(VideoCodec codec) : impl_(std::make_unique<Impl>()) {
  if (codec == VideoCodec::H264) {
    h264_ = std::make_unique<H264Decoder>();
    return;
  }
  vpx_codec_iface_t* iface = codec == VideoCodec::Vp8 ? vpx_codec_vp8_dx() : vpx_codec_vp9_dx();
  vpx_codec_dec_cfg_t cfg{};
  cfg.threads = 1;  // libvpx's VP8 decoder threads spin-wait: on a busy machine one is faster
  if (vpx_codec_dec_init(&impl_->codec, iface, &cfg, 0) != VPX_CODEC_OK) {
    throw VideoError(vpxMessage(&impl_->codec, "libvpx refused the decoder"));
  }
  impl_->open = true;
}

VideoDecoder::~VideoDecoder() = default;

VideoDecoder::Picture VideoDecoder::decode(std::span<const uint8_t> packet) {
  if (h264_) return h264_->decode(packet);
  if (vpx_codec_decode(&impl_->codec, packet.data(), static_cast<unsigned>(packet.size()), nullptr,
                       0) != VPX_CODEC_OK) {
    throw VideoError(vpxMessage(&impl_->codec, "libvpx could not decode a packet"));
  }
  vpx_codec_iter_t iter = nullptr;
  vpx_image_t* image = vpx_codec_get_frame(&impl_->codec, &iter);
  if (image == nullptr) throw VideoError("the packet decoded to no picture");
  if (image->fmt != VPX_IMG_FMT_I420) throw VideoError("the decoded picture is not I420");
  Picture picture;
  picture.width = image->d_w;
  picture.height = image->d_h;
  picture.rgba.resize(size_t(picture.width) * picture.height * 4);
  i420ToRgba(image->planes[VPX_PLANE_Y], image->stride[VPX_PLANE_Y], image->planes[VPX_PLANE_U],
             image->stride[VPX_PLANE_U], image->planes[VPX_PLANE_V], image->stride[VPX_PLANE_V],
             picture.width, picture.height, picture.rgba.data());
  return picture;
}

}  // namespace myriad::encode
