// H.264 (OpenH264) and the standard containers of video streams (encode/video_container.h): the
// H.264 encoder's packets decode (OpenH264's decoder) close to the source, key frames first and on
// request, its SPS says Constrained Baseline at h264Level's level (what X-Myriad-Codec names);
// the WebM and fragmented MP4 writers' bytes, read back here element by element and box by box,
// say what video_container.h promises; and the stream query refuses pairs that do not go together,
// naming `container`. The video_players CTest has ffmpeg open the same bytes over HTTP.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "encode/video.h"
#include "encode/video_container.h"
#include "service/frame_query.h"

using namespace myriad::encode;

namespace {

std::vector<uint8_t> gradient(uint32_t w, uint32_t h, uint32_t shift) {
  std::vector<uint8_t> rgba(size_t(w) * h * 4);
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = &rgba[(size_t(y) * w + x) * 4];
      const float dx = float(x) - float(shift), dy = float(y) - h / 2.0f;
      const float disc = std::exp(-(dx * dx + dy * dy) / (0.01f * w * h));
      p[0] = uint8_t(std::min(255.0f, 180.0f * x / (w - 1) + 70.0f * disc));
      p[1] = uint8_t(std::min(255.0f, 100.0f * y / (h - 1) + 150.0f * disc));
      p[2] = uint8_t(50.0f + 190.0f * disc);
      p[3] = 255;
    }
  }
  return rgba;
}

// ---- A minimal EBML reader: enough to walk what WebmWriter writes.
struct Ebml {
  std::string_view bytes;
  size_t at = 0;

  uint64_t vint(bool keepMarker) {
    const uint8_t first = uint8_t(bytes.at(at));
    int length = 1;
    while (length <= 8 && !(first & (0x80 >> (length - 1)))) ++length;
    REQUIRE(length <= 8);
    uint64_t value = keepMarker ? first : (first & (0xFF >> length));
    for (int i = 1; i < length; ++i) value = (value << 8) | uint8_t(bytes.at(at + i));
    at += size_t(length);
    return value;
  }
  static constexpr uint64_t kUnknown = 0x00FFFFFFFFFFFFFFull;  // 8-byte all-ones, marker removed
  // The next element's id and size (kUnknown for unknown), leaving `at` at its body.
  std::pair<uint64_t, uint64_t> element() {
    const uint64_t id = vint(true);
    const uint64_t size = vint(false);
    return {id, size};
  }
  uint64_t uintBody(uint64_t size) {
    uint64_t v = 0;
    for (uint64_t i = 0; i < size; ++i) v = (v << 8) | uint8_t(bytes.at(at++));
    return v;
  }
  std::string stringBody(uint64_t size) {
    std::string s(bytes.substr(at, size));
    at += size;
    return s;
  }
};

// ---- A minimal ISO BMFF reader: boxes as (type, body).
struct Box {
  std::string type;
  std::string_view body;
  size_t offset = 0;  // of the box's first byte in what was read
};
uint32_t be32(std::string_view b, size_t at) {
  return uint32_t(uint8_t(b.at(at))) << 24 | uint32_t(uint8_t(b.at(at + 1))) << 16 |
         uint32_t(uint8_t(b.at(at + 2))) << 8 | uint8_t(b.at(at + 3));
}
std::vector<Box> boxes(std::string_view bytes, size_t base = 0) {
  std::vector<Box> out;
  for (size_t at = 0; at < bytes.size();) {
    const uint32_t size = be32(bytes, at);
    REQUIRE(size >= 8);
    REQUIRE(at + size <= bytes.size());
    out.push_back(
        {std::string(bytes.substr(at + 4, 4)), bytes.substr(at + 8, size - 8), base + at});
    at += size;
  }
  return out;
}
const Box& child(const std::vector<Box>& list, const std::string& type) {
  for (const Box& b : list) {
    if (b.type == type) return b;
  }
  FAIL("no " << type << " box");
  throw std::logic_error("unreachable");
}

std::vector<VideoPacket> encodeFrames(VideoCodec codec, uint32_t w, uint32_t h, int frames,
                                      int forcedKeyAt) {
  VideoEncoder encoder({codec, w, h, 30, 1500, 2});
  std::vector<VideoPacket> packets;
  for (int i = 0; i < frames; ++i) {
    packets.push_back(
        encoder.encode(gradient(w, h, uint32_t(20 + 8 * i)), uint64_t(i) * 33, i == forcedKeyAt));
  }
  return packets;
}

}  // namespace

TEST_CASE("video: H.264 round trip: Constrained Baseline, key frames first and on request") {
  constexpr uint32_t w = 322, h = 182;  // not multiples of 16: cropped in the SPS
  VideoEncoder encoder({VideoCodec::H264, w, h, 30, 1500, 2});
  VideoDecoder decoder(VideoCodec::H264);
  double encodeMs = 0.0;
  for (int frame = 0; frame < 10; ++frame) {
    CAPTURE(frame);
    std::vector<uint8_t> source = gradient(w, h, uint32_t(40 + 10 * frame));
    const auto start = std::chrono::steady_clock::now();
    VideoPacket packet = encoder.encode(source, uint64_t(frame) * 33, frame == 6);
    encodeMs +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    CHECK(packet.key == (frame == 0 || frame == 6));
    std::vector<std::span<const uint8_t>> units = annexBNalUnits(packet.data);
    REQUIRE(!units.empty());
    if (packet.key) {
      // SPS, PPS, then the IDR slice(s); the SPS: profile 66, constraint_set0+1, the level.
      REQUIRE((units[0][0] & 0x1F) == 7);
      CHECK((units[1][0] & 0x1F) == 8);
      CHECK((units.back()[0] & 0x1F) == 5);
      CHECK(units[0][1] == 66);
      CHECK(units[0][2] == 0xC0);
      CHECK(units[0][3] == h264Level(w, h, 30, 1500));
      char expected[16];
      std::snprintf(expected, sizeof expected, "avc1.42C0%02X", units[0][3]);
      CHECK(webCodecsName(VideoCodec::H264, w, h, 30, 1500) == expected);
    } else {
      CHECK((units[0][0] & 0x1F) == 1);  // a non-IDR slice
    }
    VideoDecoder::Picture picture = decoder.decode(packet.data);
    REQUIRE(picture.width == w);
    REQUIRE(picture.height == h);
    const double psnr = psnrRgb(picture.rgba, source);
    CHECK(psnr > 30.0);
    if (frame == 0 || frame == 9) MESSAGE("h264 frame ", frame, ": ", psnr, " dB");
  }
  MESSAGE("h264 ", w, "x", h, ": ", encodeMs / 10, " ms a frame (2 threads)");
  encoder.setBitrate(500);
  CHECK(encoder.settings().bitrateKbps == 500);
  CHECK(!encoder.encode(gradient(w, h, 200), 400, false).data.empty());
  // Odd sizes and frames beyond level 5.2 are refused by name.
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::H264, 321, 180, 30, 1000, 1}), std::invalid_argument);
  CHECK_THROWS_AS(VideoEncoder({VideoCodec::H264, 4096, 4096, 30, 1000, 1}), std::invalid_argument);
  // Levels: frame size, macroblock rate and bitrate each push it up.
  CHECK(h264Level(320, 180, 15, 100) == 12);
  CHECK(h264Level(320, 180, 15, 1000) == 20);
  CHECK(h264Level(1920, 1080, 30, 6000) == 40);
  CHECK(h264Level(1920, 1080, 60, 6000) == 42);
  CHECK(h264Level(3840, 2160, 30, 20000) == 51);
  CHECK(h264Level(4096, 4096, 30, 1000) == 0);
}

TEST_CASE("video: live WebM: EBML header, unknown-size Segment and Clusters, SimpleBlocks") {
  constexpr uint32_t w = 160, h = 90;
  std::vector<VideoPacket> packets = encodeFrames(VideoCodec::Vp9, w, h, 6, 3);
  auto writer = makeContainerWriter(VideoContainer::Webm, VideoCodec::Vp9, w, h, 30);
  // The channel's clock started before this stream: its first frame is at 0 all the same.
  const uint64_t baseUs = 5'000'000;
  std::string bytes;
  std::vector<size_t> frameEnds;
  for (size_t i = 0; i < packets.size(); ++i) {
    bytes += writer->frame(packets[i].data, packets[i].key, baseUs + i * 33'333);
    frameEnds.push_back(bytes.size());
  }
  bytes += writer->keepAlive();
  // After a 40 s still scene: 1 / 30 s after the frame before (a contiguous timeline).
  bytes += writer->frame(packets[5].data, false, baseUs + 40'000'000);
  // Blocks whose time is more than int16 milliseconds past their cluster's (no key frame in 33 s
  // of frames: more than the encoders allow, but the writer does not count on it) open a cluster.
  for (int i = 1; i <= 1000; ++i) {
    bytes += writer->frame(packets[5].data, false, baseUs + 40'000'000 + uint64_t(i) * 33'333);
  }

  Ebml r{bytes};
  auto [id, size] = r.element();
  REQUIRE(id == 0x1A45DFA3);
  std::map<uint64_t, std::string> header;
  const size_t headerEnd = r.at + size;
  while (r.at < headerEnd) {
    auto [hid, hsize] = r.element();
    header[hid] = hid == 0x4282 ? r.stringBody(hsize) : std::to_string(r.uintBody(hsize));
  }
  CHECK(header[0x4282] == "webm");
  CHECK(header[0x4285] == "2");
  std::tie(id, size) = r.element();
  REQUIRE(id == 0x18538067);
  CHECK(size == Ebml::kUnknown);
  std::tie(id, size) = r.element();
  REQUIRE(id == 0x1549A966);  // Info
  const size_t infoEnd = r.at + size;
  auto [sid, ssize] = r.element();
  CHECK(sid == 0x2AD7B1);
  CHECK(r.uintBody(ssize) == 1000000);
  r.at = infoEnd;
  std::tie(id, size) = r.element();
  REQUIRE(id == 0x1654AE6B);  // Tracks
  const std::string tracks = r.stringBody(size);
  CHECK(tracks.find("V_VP9") != std::string::npos);

  struct Block {
    uint64_t clusterMs;
    int relativeMs;
    bool key;
    size_t bytes;
  };
  std::vector<Block> blocks;
  int voids = 0, clusters = 0;
  uint64_t clusterMs = 0;
  while (r.at < bytes.size()) {
    std::tie(id, size) = r.element();
    if (id == 0x1F43B675) {  // Cluster: unknown size, its Timestamp first
      CHECK(size == Ebml::kUnknown);
      ++clusters;
      auto [tid, tsize] = r.element();
      REQUIRE(tid == 0xE7);
      clusterMs = r.uintBody(tsize);
    } else if (id == 0xA3) {  // SimpleBlock
      const std::string_view body = std::string_view(bytes).substr(r.at, size);
      CHECK(uint8_t(body[0]) == 0x81);  // track 1
      const int relative = int16_t(uint16_t(uint8_t(body[1])) << 8 | uint8_t(body[2]));
      blocks.push_back({clusterMs, relative, (uint8_t(body[3]) & 0x80) != 0, size - 4});
      r.at += size;
    } else if (id == 0xEC) {  // Void: the keep-alive
      ++voids;
      r.at += size;
    } else {
      FAIL("unexpected element " << id);
    }
  }
  REQUIRE(blocks.size() == 1007);
  CHECK(voids == 1);
  CHECK(clusters == 3);  // at frame 0 (key), frame 3 (key), and 32.767 s of blocks later
  for (size_t i = 0; i < packets.size(); ++i) {
    CAPTURE(i);
    CHECK(blocks[i].key == packets[i].key);
    CHECK(blocks[i].bytes == packets[i].data.size());
    CHECK(blocks[i].clusterMs + blocks[i].relativeMs == i * 33'333 / 1000);
  }
  CHECK(blocks[6].clusterMs + blocks[6].relativeMs == (5 * 33'333 + 33'333) / 1000);
  for (size_t i = 1; i < blocks.size(); ++i) {
    CAPTURE(i);
    CHECK(blocks[i].relativeMs >= 0);
    const uint64_t previous = blocks[i - 1].clusterMs + blocks[i - 1].relativeMs;
    const uint64_t now = blocks[i].clusterMs + blocks[i].relativeMs;
    CHECK(now - previous <= 34);  // never more than 1 / 30 s: the gap is left out
  }
  // The first frame must be a key frame; timestamps never go back.
  auto other = makeContainerWriter(VideoContainer::Webm, VideoCodec::Vp8, w, h, 30);
  CHECK_THROWS_AS(other->frame(packets[1].data, false, 0), std::invalid_argument);
  CHECK_THROWS_AS(makeContainerWriter(VideoContainer::Webm, VideoCodec::H264, w, h, 30),
                  std::invalid_argument);
}

TEST_CASE("video: fragmented MP4: ftyp, moov with avcC, then moof + mdat per frame") {
  constexpr uint32_t w = 160, h = 90;
  std::vector<VideoPacket> packets = encodeFrames(VideoCodec::H264, w, h, 5, 3);
  auto writer = makeContainerWriter(VideoContainer::Mp4, VideoCodec::H264, w, h, 30);
  const uint64_t baseUs = 7'000'000;
  std::string bytes;
  // Frames 25 ms apart (faster than 1 / 30 s), except a 3 s gap before frame 2: the gap is
  // left out of the timeline (at most one duration, 3000 ticks of 90 kHz).
  const uint64_t sentUs[] = {0, 25'000, 3'025'000, 3'050'000, 3'075'000};
  const uint64_t expectedTicks[] = {0, 2250, 5250, 7500, 9750};
  for (size_t i = 0; i < packets.size(); ++i) {
    bytes += writer->frame(packets[i].data, packets[i].key, baseUs + sentUs[i]);
    if (i == 1) bytes += writer->keepAlive();
  }
  std::vector<Box> top = boxes(bytes);
  REQUIRE(top.size() == 2 + 2 * packets.size() + 1);
  CHECK(top[0].type == "ftyp");
  REQUIRE(top[1].type == "moov");
  // moov/trak/mdia/minf/stbl/stsd/avc1/avcC: the first key frame's SPS and PPS.
  const std::vector<Box> moov = boxes(top[1].body);
  const std::vector<Box> mdia = boxes(child(boxes(child(moov, "trak").body), "mdia").body);
  const std::string_view mdhd = child(mdia, "mdhd").body;
  CHECK(be32(mdhd, 12) == 90000);  // timescale
  const std::vector<Box> stbl = boxes(
      child(boxes(child(boxes(child(mdia, "minf").body), "stbl").body), "stsd").body.substr(8));
  REQUIRE(stbl.size() == 1);
  CHECK(stbl[0].type == "avc1");
  const std::string_view avc1 = stbl[0].body;
  CHECK((uint8_t(avc1[24]) << 8 | uint8_t(avc1[25])) == w);
  CHECK((uint8_t(avc1[26]) << 8 | uint8_t(avc1[27])) == h);
  const std::string_view avcC = child(boxes(avc1.substr(78)), "avcC").body;
  std::vector<std::span<const uint8_t>> units = annexBNalUnits(packets[0].data);
  const size_t spsBytes = uint8_t(avcC[6]) << 8 | uint8_t(avcC[7]);
  REQUIRE(spsBytes == units[0].size());
  CHECK(std::string_view(avcC.substr(8, spsBytes)) ==
        std::string_view(reinterpret_cast<const char*>(units[0].data()), units[0].size()));
  CHECK(uint8_t(avcC[1]) == 66);
  CHECK(uint8_t(avcC[4]) == 0xFF);  // 4-byte NAL lengths
  CHECK(child(moov, "mvex").type == "mvex");

  size_t frame = 0;
  for (size_t i = 2; i < top.size(); ++i) {
    if (top[i].type == "free") continue;  // the keep-alive
    CAPTURE(frame);
    REQUIRE(top[i].type == "moof");
    REQUIRE(top[i + 1].type == "mdat");
    const std::vector<Box> moof = boxes(top[i].body);
    CHECK(be32(child(moof, "mfhd").body, 4) == frame + 1);
    const std::vector<Box> traf = boxes(child(moof, "traf").body);
    const std::string_view tfdt = child(traf, "tfdt").body;
    CHECK(uint8_t(tfdt[0]) == 1);
    const uint64_t decodeTime = uint64_t(be32(tfdt, 4)) << 32 | be32(tfdt, 8);
    CHECK(decodeTime == expectedTicks[frame]);
    const std::string_view trun = child(traf, "trun").body;
    CHECK(be32(trun, 4) == 1);      // one sample
    CHECK(be32(trun, 12) == 3000);  // the declared duration: 1 / 30 s
    const uint32_t dataOffset = be32(trun, 8);
    const uint32_t sampleBytes = be32(trun, 16);
    const uint32_t flags = be32(trun, 20);
    CHECK(dataOffset == top[i].body.size() + 8 + 8);  // past the moof and mdat's header
    CHECK(sampleBytes == top[i + 1].body.size());
    CHECK((flags == 0x02000000) == packets[frame].key);
    // The sample: length-prefixed NAL units, the slices of the packet without SPS and PPS.
    std::string_view sample = top[i + 1].body;
    size_t expectedBytes = 0;
    for (std::span<const uint8_t> unit : annexBNalUnits(packets[frame].data)) {
      const uint8_t type = unit[0] & 0x1F;
      if (type != 7 && type != 8) expectedBytes += 4 + unit.size();
    }
    CHECK(sample.size() == expectedBytes);
    for (size_t at = 0; at < sample.size();) {
      const uint32_t length = be32(sample, at);
      const uint8_t type = uint8_t(sample[at + 4]) & 0x1F;
      CHECK((type == 1 || type == 5));
      at += 4 + length;
    }
    ++frame;
    ++i;
  }
  CHECK(frame == packets.size());
  CHECK_THROWS_AS(makeContainerWriter(VideoContainer::Mp4, VideoCodec::Vp9, w, h, 30),
                  std::invalid_argument);
}

TEST_CASE("stream query: container pairs with its codec, or 400 naming container") {
  using myriad::service::FrameQueryError;
  using myriad::service::parseStreamQuery;
  auto parse = [](std::string codec, std::string container) {
    myriad::service::QueryParams params{{"width", "320"}, {"height", "180"}};
    if (!codec.empty()) params.emplace("codec", codec);
    if (!container.empty()) params.emplace("container", container);
    return parseStreamQuery(params, 4096);
  };
  CHECK(parse("vp9", "").video->container == VideoContainer::Myriad);
  CHECK(parse("vp9", "webm").video->container == VideoContainer::Webm);
  CHECK(parse("vp8", "webm").video->container == VideoContainer::Webm);
  CHECK(parse("h264", "").video->container == VideoContainer::Mp4);
  CHECK(parse("h264", "mp4").video->codec == VideoCodec::H264);
  for (auto [codec, container] :
       {std::pair{"h264", "webm"}, std::pair{"h264", "myriad"}, std::pair{"vp9", "mp4"},
        std::pair{"vp8", "ogg"}, std::pair{"", "webm"}}) {
    CAPTURE(codec);
    CAPTURE(container);
    try {
      parse(codec, container);
      FAIL("accepted");
    } catch (const FrameQueryError& e) {
      CHECK(e.parameter() == "container");
    }
  }
  try {
    myriad::service::QueryParams params{{"width", "321"}, {"height", "180"}, {"codec", "h264"}};
    parseStreamQuery(params, 4096);
    FAIL("accepted");
  } catch (const FrameQueryError& e) {
    CHECK(e.parameter() == "width");
  }
}
