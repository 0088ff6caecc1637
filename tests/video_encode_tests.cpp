// Video encoding of frames (libvpx VP8 and VP9): what the encoder produces decodes (with libvpx's
// decoder) to the same size and close to the source, key frames come first and on request, the
// bitrate follows the target, and bad settings are refused by name.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "encode/video.h"

using namespace myriad::encode;

namespace {

// Smooth gradients with a bright disc at (cx, cy): a rendered-looking picture that moves.
std::vector<uint8_t> movingImage(uint32_t w, uint32_t h, float cx, float cy) {
  std::vector<uint8_t> rgba(size_t(w) * h * 4);
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = &rgba[(size_t(y) * w + x) * 4];
      const float dx = x - cx, dy = y - cy;
      const float disc = std::exp(-(dx * dx + dy * dy) / (0.01f * w * h));
      p[0] = uint8_t(std::min(255.0f, 200.0f * x / (w - 1) + 55.0f * disc));
      p[1] = uint8_t(std::min(255.0f, 120.0f * y / (h - 1) + 135.0f * disc));
      p[2] = uint8_t(60.0f + 180.0f * disc);
      p[3] = 255;
    }
  }
  return rgba;
}

}  // namespace

TEST_CASE("video: VP8 and VP9 round trips: a key frame first, deltas after, forced keys") {
  for (VideoCodec codec : {VideoCodec::Vp8, VideoCodec::Vp9}) {
    CAPTURE(videoCodecName(codec));
    constexpr uint32_t w = 322, h = 182;  // not multiples of 16 (nor of 4 in their halves)
    VideoEncoder encoder({codec, w, h, 30, 2000, 2});
    VideoDecoder decoder(codec);
    for (int frame = 0; frame < 12; ++frame) {
      CAPTURE(frame);
      std::vector<uint8_t> source = movingImage(w, h, 40.0f + 20.0f * frame, 90.0f);
      const bool forceKey = frame == 8;
      VideoPacket packet = encoder.encode(source, uint64_t(frame) * 33, forceKey);
      CHECK(!packet.data.empty());
      CHECK(packet.key == (frame == 0 || frame == 8));
      VideoDecoder::Picture picture = decoder.decode(packet.data);
      REQUIRE(picture.width == w);
      REQUIRE(picture.height == h);
      const double psnr = psnrRgb(picture.rgba, source);
      if (frame == 0 || frame == 11) MESSAGE(videoCodecName(codec), " frame ", frame, ": ", psnr, " dB, ", packet.data.size(), " bytes");
      CHECK(psnr > 30.0);
    }
    // A key frame decodes alone, in a decoder that saw nothing before.
    VideoPacket key = encoder.encode(movingImage(w, h, 100.0f, 50.0f), 500, true);
    REQUIRE(key.key);
    VideoDecoder fresh(codec);
    CHECK(psnrRgb(fresh.decode(key.data).rgba, movingImage(w, h, 100.0f, 50.0f)) > 30.0);
  }
}

TEST_CASE("video: the bitrate follows the target over a second of moving frames") {
  constexpr uint32_t w = 320, h = 180;
  for (uint32_t kbps : {200u, 1500u}) {
    CAPTURE(kbps);
    VideoEncoder encoder({VideoCodec::Vp8, w, h, 30, kbps, 2});
    size_t bytes = 0;
    for (int frame = 0; frame < 60; ++frame) {
      // Noise-like change every frame, so the encoder has to spend bits.
      std::vector<uint8_t> source = movingImage(w, h, 10.0f + 5.0f * frame, 20.0f + 2.5f * frame);
      for (size_t i = 0; i < source.size(); i += 4) source[i] ^= uint8_t((i * 2654435761u + frame * 97u) >> 27);
      bytes += encoder.encode(source, uint64_t(frame) * 1000 / 30, false).data.size();
    }
    const double measuredKbps = bytes * 8.0 / 2.0 / 1000.0;  // 60 frames = 2 s
    MESSAGE("target ", kbps, " kbit/s: ", measuredKbps, " kbit/s");
    CHECK(measuredKbps < kbps * 1.6);
    CHECK(measuredKbps > kbps * 0.3);
  }
}

TEST_CASE("video: a new bitrate takes effect without a key frame") {
  constexpr uint32_t w = 320, h = 180;
  for (VideoCodec codec : {VideoCodec::Vp8, VideoCodec::Vp9}) {
    CAPTURE(videoCodecName(codec));
    VideoEncoder encoder({codec, w, h, 30, 1500, 2});
    VideoDecoder decoder(codec);
    size_t high = 0, low = 0;
    for (int frame = 0; frame < 120; ++frame) {
      if (frame == 60) {
        encoder.setBitrate(300);
        CHECK(encoder.settings().bitrateKbps == 300);
      }
      std::vector<uint8_t> source = movingImage(w, h, 10.0f + 2.5f * frame, 20.0f + 1.2f * frame);
      for (size_t i = 0; i < source.size(); i += 4) source[i] ^= uint8_t((i * 2654435761u + frame * 97u) >> 27);
      VideoPacket packet = encoder.encode(source, uint64_t(frame) * 1000 / 30, false);
      CHECK(packet.key == (frame == 0));
      CHECK(decoder.decode(packet.data).width == w);  // the stream stays decodable
      // The second after the change, less its first 10 frames (the buffer drains).
      if (frame >= 30 && frame < 60) high += packet.data.size();
      if (frame >= 90) low += packet.data.size();
    }
    MESSAGE(videoCodecName(codec), ": ", high * 8 / 1000, " kbit/s at 1500, ", low * 8 / 1000,
            " kbit/s after setBitrate(300)");
    CHECK(low * 2 < high);
  }
  VideoEncoder encoder({VideoCodec::Vp9, 64, 64, 30, 500, 1});
  CHECK_THROWS_AS(encoder.setBitrate(0), std::invalid_argument);
}

TEST_CASE("video: colour conversion keeps flat colours within two levels") {
  for (auto [r, g, b] : {std::array{0, 0, 0}, std::array{255, 255, 255}, std::array{200, 40, 90},
                         std::array{12, 180, 250}}) {
    CAPTURE(r);
    CAPTURE(g);
    CAPTURE(b);
    constexpr uint32_t w = 5, h = 3;  // odd: the last chroma column and row cover one pixel
    std::vector<uint8_t> rgba(w * h * 4);
    for (size_t i = 0; i < rgba.size(); i += 4) {
      rgba[i] = uint8_t(r);
      rgba[i + 1] = uint8_t(g);
      rgba[i + 2] = uint8_t(b);
      rgba[i + 3] = 255;
    }
    std::vector<uint8_t> y(w * h), u(3 * 2), v(3 * 2), back(w * h * 4);
    rgbaToI420(rgba, w, h, y.data(), w, u.data(), 3, v.data(), 3);
    i420ToRgba(y.data(), w, u.data(), 3, v.data(), 3, w, h, back.data());
    for (size_t i = 0; i < back.size(); ++i) {
      CHECK(std::abs(int(back[i]) - int(rgba[i])) <= 2);
    }
  }
}

TEST_CASE("video: bad settings and frames are refused by name") {
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::Vp8, 1, 64, 30, 1000, 1}), std::invalid_argument);
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::Vp8, 64, 20000, 30, 1000, 1}), std::invalid_argument);
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::Vp9, 64, 64, 0, 1000, 1}), std::invalid_argument);
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::Vp9, 64, 64, 30, 0, 1}), std::invalid_argument);
  VideoEncoder encoder({VideoCodec::Vp8, 64, 64, 30, 1000, 1});
  std::vector<uint8_t> wrong(64 * 63 * 4);
  CHECK_THROWS_WITH_AS(encoder.encode(wrong, 0, false), doctest::Contains("expected 16384"),
                       std::invalid_argument);
  VideoDecoder decoder(VideoCodec::Vp8);
  std::vector<uint8_t> garbage(100, 0x5a);
  CHECK_THROWS_AS(decoder.decode(garbage), VideoError);
  CHECK(psnrRgb(wrong, wrong) == INFINITY);
  CHECK_THROWS_AS(psnrRgb(wrong, std::vector<uint8_t>(4)), std::invalid_argument);
}
