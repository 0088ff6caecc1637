// H.264 for GET .../stream?codec=h264 (OpenH264, BSD-licensed, Debian's libopenh264): the
// encoder and decoder behind encode::VideoEncoder / VideoDecoder when their codec is H264. Kept
// apart from video.cpp's libvpx code; nothing outside encode/ includes this header.
//
// What the encoder makes: Constrained Baseline (profile_idc 66, constraint_set1: CAVLC, no
// B-frames, no FMO/ASO, so every browser and hardware decoder plays it), one slice per thread,
// constant SPS/PPS ids (the same SPS and PPS before every IDR, so an MP4 init segment built from
// the first one describes the whole stream), a VUI saying BT.601 studio range (what
// rgbaToI420 makes). Each packet is Annex B (start codes); an IDR's carries SPS and PPS first.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "encode/video.h"

namespace myriad::encode {

class H264Encoder {
 public:
  // Throws VideoError when OpenH264 refuses the settings (VideoEncoder checked their ranges) or
  // std::invalid_argument for an odd size or a frame larger than level 5.2's.
  explicit H264Encoder(const VideoSettings& settings);
  ~H264Encoder();
  H264Encoder(const H264Encoder&) = delete;
  H264Encoder& operator=(const H264Encoder&) = delete;

  VideoPacket encode(std::span<const uint8_t> rgba, uint64_t timestampMs, bool forceKey);
  void setBitrate(uint32_t kbps);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class H264Decoder {
 public:
  H264Decoder();
  ~H264Decoder();
  H264Decoder(const H264Decoder&) = delete;
  H264Decoder& operator=(const H264Decoder&) = delete;

  // The picture of one Annex B packet; throws VideoError when it does not decode to one.
  VideoDecoder::Picture decode(std::span<const uint8_t> packet);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace myriad::encode
