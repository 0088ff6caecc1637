// Live WebM of VP8/VP9 frames (video_container.h describes the layout) and what both container
// writers share: names, the codec/container pairs, the factory, Annex B splitting.
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "encode/video_container.h"
#include "protocol/constants.h"

namespace myriad::encode {
namespace {

// Matroska element IDs (their bytes include the length marker, as written).
constexpr uint32_t kEbml = 0x1A45DFA3;
constexpr uint32_t kEbmlVersion = 0x4286;
constexpr uint32_t kEbmlReadVersion = 0x42F7;
constexpr uint32_t kEbmlMaxIdLength = 0x42F2;
constexpr uint32_t kEbmlMaxSizeLength = 0x42F3;
constexpr uint32_t kDocType = 0x4282;
constexpr uint32_t kDocTypeVersion = 0x4287;
constexpr uint32_t kDocTypeReadVersion = 0x4285;
constexpr uint32_t kSegment = 0x18538067;
constexpr uint32_t kInfo = 0x1549A966;
constexpr uint32_t kTimestampScale = 0x2AD7B1;
constexpr uint32_t kMuxingApp = 0x4D80;
constexpr uint32_t kWritingApp = 0x5741;
constexpr uint32_t kTracks = 0x1654AE6B;
constexpr uint32_t kTrackEntry = 0xAE;
constexpr uint32_t kTrackNumber = 0xD7;
constexpr uint32_t kTrackUid = 0x73C5;
constexpr uint32_t kTrackType = 0x83;
constexpr uint32_t kFlagLacing = 0x9C;
constexpr uint32_t kCodecId = 0x86;
constexpr uint32_t kVideo = 0xE0;
constexpr uint32_t kPixelWidth = 0xB0;
constexpr uint32_t kPixelHeight = 0xBA;
constexpr uint32_t kColour = 0x55B0;
constexpr uint32_t kMatrixCoefficients = 0x55B1;
constexpr uint32_t kRange = 0x55B9;
constexpr uint32_t kCluster = 0x1F43B675;
constexpr uint32_t kClusterTimestamp = 0xE7;
constexpr uint32_t kSimpleBlock = 0xA3;
constexpr uint32_t kVoid = 0xEC;

// The 8-byte "unknown size" (all value bits set): a live Segment's and Cluster's.
constexpr char kUnknownSize[8] = {0x01,       char(0xFF), char(0xFF), char(0xFF),
                                  char(0xFF), char(0xFF), char(0xFF), char(0xFF)};

void putId(std::string& out, uint32_t id) {
  int bytes = id > 0xFFFFFF ? 4 : id > 0xFFFF ? 3 : id > 0xFF ? 2 : 1;
  while (bytes-- > 0) out.push_back(char((id >> (8 * bytes)) & 0xFF));
}

// An element size as an EBML variable-length integer of the fewest bytes (all-ones is reserved
// for "unknown", hence 2^(7n) - 2 as each length's largest value).
void putSize(std::string& out, uint64_t size) {
  int length = 1;
  while (length < 8 && size >= (uint64_t(1) << (7 * length)) - 1) ++length;
  const uint64_t marked = size | (uint64_t(1) << (7 * length));
  for (int i = length - 1; i >= 0; --i) out.push_back(char((marked >> (8 * i)) & 0xFF));
}

void putElement(std::string& out, uint32_t id, std::string_view body) {
  putId(out, id);
  putSize(out, body.size());
  out.append(body);
}

void putUint(std::string& out, uint32_t id, uint64_t value) {
  std::string body;
  int bytes = 1;
  while (bytes < 8 && (value >> (8 * bytes)) != 0) ++bytes;
  while (bytes-- > 0) body.push_back(char((value >> (8 * bytes)) & 0xFF));
  putElement(out, id, body);
}

class WebmWriter final : public ContainerWriter {
 public:
  WebmWriter(VideoCodec codec, uint32_t width, uint32_t height, uint32_t fps)
      : codec_(codec), width_(width), height_(height), intervalUs_(1000000 / std::max(1u, fps)) {}

  std::string frame(std::span<const uint8_t> packet, bool key, uint64_t timestampUs) override {
    std::string out;
    if (!started_) {
      if (!key) throw std::invalid_argument("a WebM stream must begin with a key frame");
      out = header();
      started_ = true;
    } else {
      if (timestampUs < lastUs_) {
        throw std::invalid_argument("WebM block timestamps must not go back");
      }
      // The real interval, but at most 1 / fps (video_container.h: a contiguous timeline).
      timeUs_ += std::min<uint64_t>(timestampUs - lastUs_, intervalUs_);
    }
    lastUs_ = timestampUs;
    const uint64_t ms = timeUs_ / 1000;
    if (!inCluster_ || key || ms - clusterMs_ > uint64_t(std::numeric_limits<int16_t>::max())) {
      putId(out, kCluster);
      out.append(kUnknownSize, sizeof kUnknownSize);
      putUint(out, kClusterTimestamp, ms);
      clusterMs_ = ms;
      inCluster_ = true;
    }
    // SimpleBlock: track number (vint), int16 timestamp relative to the cluster's, flags.
    const uint16_t relative = static_cast<uint16_t>(ms - clusterMs_);
    putId(out, kSimpleBlock);
    putSize(out, 4 + packet.size());
    out.push_back(char(0x81));  // track 1
    out.push_back(char(relative >> 8));
    out.push_back(char(relative & 0xFF));
    out.push_back(char(key ? 0x80 : 0x00));
    out.append(reinterpret_cast<const char*>(packet.data()), packet.size());
    return out;
  }

  std::string keepAlive() const override { return std::string{char(kVoid), char(0x81), '\0'}; }

 private:
  std::string header() const {
    std::string out;
    std::string ebml;
    putUint(ebml, kEbmlVersion, 1);
    putUint(ebml, kEbmlReadVersion, 1);
    putUint(ebml, kEbmlMaxIdLength, 4);
    putUint(ebml, kEbmlMaxSizeLength, 8);
    putElement(ebml, kDocType, "webm");
    putUint(ebml, kDocTypeVersion, 4);
    putUint(ebml, kDocTypeReadVersion, 2);  // SimpleBlock came with version 2
    putElement(out, kEbml, ebml);

    putId(out, kSegment);
    out.append(kUnknownSize, sizeof kUnknownSize);
    std::string info;
    putUint(info, kTimestampScale, 1000000);  // nanoseconds a tick: block timestamps in ms
    putElement(info, kMuxingApp, "myriad");
    putElement(info, kWritingApp, "myriad-server");
    putElement(out, kInfo, info);

    std::string colour;
    putUint(colour, kMatrixCoefficients, 6);  // BT.601 (SMPTE 170M)
    putUint(colour, kRange, 1);               // broadcast (studio) range
    std::string video;
    putUint(video, kPixelWidth, width_);
    putUint(video, kPixelHeight, height_);
    putElement(video, kColour, colour);
    std::string track;
    putUint(track, kTrackNumber, 1);
    putUint(track, kTrackUid, 1);
    putUint(track, kTrackType, 1);  // video
    putUint(track, kFlagLacing, 0);
    putElement(track, kCodecId, codec_ == VideoCodec::Vp8 ? "V_VP8" : "V_VP9");
    putElement(track, kVideo, video);
    std::string tracks;
    putElement(tracks, kTrackEntry, track);
    putElement(out, kTracks, tracks);
    return out;
  }

  VideoCodec codec_;
  uint32_t width_, height_;
  uint64_t intervalUs_;  // 1 / fps
  bool started_ = false;
  bool inCluster_ = false;
  uint64_t lastUs_ = 0;  // the last frame's encoder timestamp
  uint64_t timeUs_ = 0;  // the last frame's time in the stream
  uint64_t clusterMs_ = 0;
};

}  // namespace

std::unique_ptr<ContainerWriter> makeMp4Writer(uint32_t width, uint32_t height, uint32_t fps);

std::string_view videoContainerName(VideoContainer container) {
  return protocol::kVideoContainers[static_cast<size_t>(container)];
}

bool containerCarries(VideoContainer container, VideoCodec codec) {
  return container == VideoContainer::Mp4 ? codec == VideoCodec::H264 : codec != VideoCodec::H264;
}

std::unique_ptr<ContainerWriter> makeContainerWriter(VideoContainer container, VideoCodec codec,
                                                     uint32_t width, uint32_t height,
                                                     uint32_t fps) {
  if (container == VideoContainer::Myriad || !containerCarries(container, codec)) {
    throw std::invalid_argument("container " + std::string(videoContainerName(container)) +
                                " has no writer for " + std::string(videoCodecName(codec)));
  }
  if (container == VideoContainer::Webm)
    return std::make_unique<WebmWriter>(codec, width, height, fps);
  return makeMp4Writer(width, height, fps);
}

std::vector<std::span<const uint8_t>> annexBNalUnits(std::span<const uint8_t> packet) {
  std::vector<std::span<const uint8_t>> units;
  const size_t n = packet.size();
  size_t begin = std::string::npos;  // the current unit's first byte
  auto close = [&](size_t end) {
    if (begin == std::string::npos) return;
    while (end > begin && packet[end - 1] == 0) --end;  // trailing zeros / a 4-byte start code
    if (end > begin) units.push_back(packet.subspan(begin, end - begin));
  };
  for (size_t i = 0; i + 2 < n;) {
    if (packet[i] == 0 && packet[i + 1] == 0 && packet[i + 2] == 1) {
      close(i);
      begin = i + 3;
      i += 3;
    } else {
      ++i;
    }
  }
  close(n);
  return units;
}

}  // namespace myriad::encode
