// Fragmented MP4 of H.264 frames (video_container.h describes the boxes). A box is written as
// its size placeholder and type, then its body, and its size patched in when it closes (BoxScope).
#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "encode/video_container.h"

namespace myriad::encode {
namespace {

constexpr uint32_t kTimescale = 90000;  // the media's ticks a second (90 kHz, as MPEG video)
constexpr uint32_t kTrackId = 1;
// trun sample flags (14496-12 8.8.3.1): a sync sample depends on nothing; any other depends on
// others (sample_depends_on 1) and is not a sync sample (sample_is_non_sync_sample).
constexpr uint32_t kSyncSampleFlags = 0x02000000;
constexpr uint32_t kOtherSampleFlags = 0x01010000;
constexpr uint8_t kNalSps = 7;
constexpr uint8_t kNalPps = 8;

void put8(std::string& out, uint32_t v) {
  out.push_back(char(v & 0xFF));
}
void put16(std::string& out, uint32_t v) {
  put8(out, v >> 8), put8(out, v);
}
void put24(std::string& out, uint32_t v) {
  put8(out, v >> 16), put16(out, v);
}
void put32(std::string& out, uint32_t v) {
  put16(out, v >> 16), put16(out, v);
}
void put64(std::string& out, uint64_t v) {
  put32(out, uint32_t(v >> 32)), put32(out, uint32_t(v));
}
void putZeros(std::string& out, size_t n) {
  out.append(n, '\0');
}
void putBytes(std::string& out, std::span<const uint8_t> bytes) {
  out.append(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

// A box open in `out` from construction to destruction; a full box also writes version and flags.
class BoxScope {
 public:
  BoxScope(std::string& out, const char (&type)[5]) : out_(out), at_(out.size()) {
    put32(out, 0);
    out.append(type, 4);
  }
  BoxScope(std::string& out, const char (&type)[5], uint8_t version, uint32_t flags)
      : BoxScope(out, type) {
    put8(out, version);
    put24(out, flags);
  }
  ~BoxScope() {
    const uint32_t size = uint32_t(out_.size() - at_);
    for (int i = 0; i < 4; ++i) out_[at_ + i] = char((size >> (24 - 8 * i)) & 0xFF);
  }
  BoxScope(const BoxScope&) = delete;
  BoxScope& operator=(const BoxScope&) = delete;

 private:
  std::string& out_;
  size_t at_;
};

// The unity matrix of mvhd and tkhd (16.16 and 2.30 fixed point).
void putMatrix(std::string& out) {
  for (uint32_t v : {0x00010000u, 0u, 0u, 0u, 0x00010000u, 0u, 0u, 0u, 0x40000000u}) put32(out, v);
}

std::string initSegment(uint32_t width, uint32_t height, std::span<const uint8_t> sps,
                        std::span<const uint8_t> pps) {
  std::string out;
  {
    BoxScope ftyp(out, "ftyp");
    out.append("isom");
    put32(out, 0x200);  // minor version
    out.append("isomiso6avc1mp41");
  }
  BoxScope moov(out, "moov");
  {
    BoxScope mvhd(out, "mvhd", 0, 0);
    put32(out, 0), put32(out, 0);  // creation, modification time
    put32(out, 1000);              // the movie's timescale (no duration: a live stream)
    put32(out, 0);                 // duration
    put32(out, 0x00010000);        // rate 1.0
    put16(out, 0x0100);            // volume 1.0
    putZeros(out, 2 + 8);
    putMatrix(out);
    putZeros(out, 6 * 4);      // pre_defined
    put32(out, kTrackId + 1);  // next_track_ID
  }
  {
    BoxScope trak(out, "trak");
    {
      BoxScope tkhd(out, "tkhd", 0, 0x000003);  // enabled, in movie
      put32(out, 0), put32(out, 0);
      put32(out, kTrackId);
      put32(out, 0);  // reserved
      put32(out, 0);  // duration
      putZeros(out, 8);
      put16(out, 0), put16(out, 0);  // layer, alternate group
      put16(out, 0), put16(out, 0);  // volume (0: not audio), reserved
      putMatrix(out);
      put32(out, width << 16), put32(out, height << 16);  // 16.16
    }
    BoxScope mdia(out, "mdia");
    {
      BoxScope mdhd(out, "mdhd", 0, 0);
      put32(out, 0), put32(out, 0);
      put32(out, kTimescale);
      put32(out, 0);
      put16(out, 0x55C4);  // language "und", packed ISO-639-2/T
      put16(out, 0);
    }
    {
      BoxScope hdlr(out, "hdlr", 0, 0);
      put32(out, 0);
      out.append("vide");
      putZeros(out, 12);
      out.append("VideoHandler");
      out.push_back('\0');
    }
    BoxScope minf(out, "minf");
    {
      BoxScope vmhd(out, "vmhd", 0, 1);
      put16(out, 0);  // graphicsmode: copy
      putZeros(out, 6);
    }
    {
      BoxScope dinf(out, "dinf");
      BoxScope dref(out, "dref", 0, 0);
      put32(out, 1);
      BoxScope url(out, "url ", 0, 1);  // the media is in this file
    }
    BoxScope stbl(out, "stbl");
    {
      BoxScope stsd(out, "stsd", 0, 0);
      put32(out, 1);
      BoxScope avc1(out, "avc1");
      putZeros(out, 6);
      put16(out, 1);  // data_reference_index
      putZeros(out, 2 + 2 + 12);
      put16(out, width), put16(out, height);
      put32(out, 0x00480000), put32(out, 0x00480000);  // 72 dpi
      put32(out, 0);
      put16(out, 1);  // frame_count
      std::string name = "myriad h264";
      put8(out, uint32_t(name.size()));
      name.resize(31, '\0');
      out.append(name);
      put16(out, 0x0018);  // depth: colour
      put16(out, 0xFFFF);  // pre_defined -1
      BoxScope avcC(out, "avcC");
      put8(out, 1);         // configurationVersion
      put8(out, sps[1]);    // AVCProfileIndication
      put8(out, sps[2]);    // profile_compatibility (the constraint flags)
      put8(out, sps[3]);    // AVCLevelIndication
      put8(out, 0xFC | 3);  // lengthSizeMinusOne 3: 4-byte NAL lengths
      put8(out, 0xE0 | 1);  // one SPS
      put16(out, uint32_t(sps.size()));
      putBytes(out, sps);
      put8(out, 1);  // one PPS
      put16(out, uint32_t(pps.size()));
      putBytes(out, pps);
    }
    // The sample tables are empty: every sample is in a fragment.
    {
      BoxScope stts(out, "stts", 0, 0);
      put32(out, 0);
    }
    {
      BoxScope stsc(out, "stsc", 0, 0);
      put32(out, 0);
    }
    {
      BoxScope stsz(out, "stsz", 0, 0);
      put32(out, 0), put32(out, 0);
    }
    {
      BoxScope stco(out, "stco", 0, 0);
      put32(out, 0);
    }
  }
  {
    BoxScope mvex(out, "mvex");
    BoxScope trex(out, "trex", 0, 0);
    put32(out, kTrackId);
    put32(out, 1);  // default_sample_description_index
    put32(out, 0), put32(out, 0), put32(out, 0);
  }
  return out;
}

class Mp4Writer final : public ContainerWriter {
 public:
  Mp4Writer(uint32_t width, uint32_t height, uint32_t fps)
      : width_(width), height_(height), duration_(kTimescale / std::max(1u, fps)) {}

  std::string frame(std::span<const uint8_t> packet, bool key, uint64_t timestampUs) override {
    std::vector<std::span<const uint8_t>> units = annexBNalUnits(packet);
    std::string out;
    if (sequence_ == 0) {
      if (!key) throw std::invalid_argument("an MP4 stream must begin with a key frame");
      std::span<const uint8_t> sps, pps;
      for (std::span<const uint8_t> unit : units) {
        if ((unit[0] & 0x1F) == kNalSps && sps.empty()) sps = unit;
        if ((unit[0] & 0x1F) == kNalPps && pps.empty()) pps = unit;
      }
      if (sps.size() < 4 || pps.empty()) {
        throw std::invalid_argument("an MP4 stream's first frame must carry its SPS and PPS");
      }
      out = initSegment(width_, height_, sps, pps);
    } else {
      if (timestampUs < lastUs_) throw std::invalid_argument("MP4 decode times must not go back");
      // The real interval, but at most the duration the last sample declared (see the header).
      decodeTime_ += std::min<uint64_t>((timestampUs - lastUs_) * kTimescale / 1000000, duration_);
    }
    lastUs_ = timestampUs;
    // The sample: every NAL unit but SPS and PPS (avcC holds them), each behind its length.
    std::string sample;
    for (std::span<const uint8_t> unit : units) {
      const uint8_t type = unit[0] & 0x1F;
      if (type == kNalSps || type == kNalPps) continue;
      put32(sample, uint32_t(unit.size()));
      putBytes(sample, unit);
    }
    const uint64_t decodeTime = decodeTime_;
    const size_t moofAt = out.size();
    size_t dataOffsetAt = 0;
    {
      BoxScope moof(out, "moof");
      {
        BoxScope mfhd(out, "mfhd", 0, 0);
        put32(out, ++sequence_);
      }
      BoxScope traf(out, "traf");
      {
        BoxScope tfhd(out, "tfhd", 0, 0x020000);  // default-base-is-moof
        put32(out, kTrackId);
      }
      {
        BoxScope tfdt(out, "tfdt", 1, 0);
        put64(out, decodeTime);
      }
      // data offset, then per sample: duration, size, flags.
      BoxScope trun(out, "trun", 0, 0x000001 | 0x000100 | 0x000200 | 0x000400);
      put32(out, 1);  // sample_count
      dataOffsetAt = out.size();
      put32(out, 0);  // data_offset, patched below
      put32(out, duration_);
      put32(out, uint32_t(sample.size()));
      put32(out, key ? kSyncSampleFlags : kOtherSampleFlags);
    }
    // The sample's first byte, from the moof's first: the moof, then mdat's 8-byte header.
    const uint32_t dataOffset = uint32_t(out.size() - moofAt + 8);
    for (int i = 0; i < 4; ++i) out[dataOffsetAt + i] = char((dataOffset >> (24 - 8 * i)) & 0xFF);
    put32(out, uint32_t(8 + sample.size()));
    out.append("mdat");
    out.append(sample);
    return out;
  }

  std::string keepAlive() const override {
    std::string out;
    { BoxScope free(out, "free"); }
    return out;
  }

 private:
  uint32_t width_, height_;
  uint32_t duration_;  // 1 / fps in kTimescale ticks: a frame's duration is not known when sent
  uint32_t sequence_ = 0;
  uint64_t lastUs_ = 0;      // the last frame's encoder timestamp
  uint64_t decodeTime_ = 0;  // the last frame's decode time, in kTimescale ticks
};

}  // namespace

std::unique_ptr<ContainerWriter> makeMp4Writer(uint32_t width, uint32_t height, uint32_t fps) {
  return std::make_unique<Mp4Writer>(width, height, fps);
}

}  // namespace myriad::encode
