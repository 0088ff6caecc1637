// Standard containers for video streams (GET .../stream?codec=...&container=webm|mp4), so that any
// player opens the stream by URL: ffmpeg, VLC, GStreamer, a <video> element through Media Source
// Extensions. Myriad's own framing (48-byte chunk headers, service/stream.cpp) stays the default
// for VP8/VP9; these writers only frame the packets an encode::VideoEncoder made.
//
// Written here rather than with a library: Debian 12's libwebm-dev carries only libwebm's parser
// (webm/webm_parser.h), not mkvmuxer, and a live stream needs few elements of either format.
//
// Live WebM (webm.cpp; Matroska's EBML, RFC 8794 and the WebM byte stream format of Media Source
// Extensions):
//   EBML header (DocType "webm", version 4, read version 2)
//   Segment, size unknown (the stream has no end known in advance):
//     Info: TimestampScale 1,000,000 (block timestamps in milliseconds), MuxingApp, WritingApp
//     Tracks: one video TrackEntry (number 1, CodecID V_VP8 or V_VP9, PixelWidth/Height, Colour:
//             BT.601 matrix, broadcast range: what encode::rgbaToI420 makes)
//     Cluster, size unknown: Timestamp (ms), then SimpleBlocks (track 1, int16 timestamp relative
//             to the cluster's, flags 0x80 on key frames), one per frame
//     Cluster ... : a new one at every key frame (so each cluster decodes on its own, which is
//             where a Media Source Extensions player may start) and whenever the next block's
//             relative timestamp would not fit int16 (32.767 s without a key frame)
//   Keep-alives: an EBML Void element (ID 0xEC, one zero byte), which every reader skips.
//
// Fragmented MP4 (mp4.cpp; ISO/IEC 14496-12 and 14496-15, the ISO BMFF byte stream format of
// Media Source Extensions), H.264 only:
//   ftyp (isom; isom, iso6, avc1, mp41)
//   moov: mvhd, trak (tkhd, mdia: mdhd with timescale 90,000, hdlr vide, minf: vmhd, dinf/dref,
//         stbl: stsd with one avc1 sample entry holding avcC (the stream's SPS and PPS, taken
//         from its first key frame), and empty stts, stsc, stsz, stco), mvex/trex
//   then per frame: moof (mfhd sequence, traf: tfhd default-base-is-moof, tfdt version 1 with the
//         frame's decode time, trun of one sample: data offset, duration, size, flags (sync or
//         not)) and mdat (the frame's NAL units, each behind a 4-byte length: avcC's
//         lengthSizeMinusOne 3; SPS and PPS left out, avcC has them)
//   Keep-alives: a free box (8 bytes), which every reader skips.
//   A frame's duration is not known when it is sent (the next frame comes when the scene next
//   changes), so each sample declares 1 / fps.
//
// Times (both containers): each writer counts from its stream's first frame (0), so every stream
// a player opens starts at 0 even when it joins a channel whose encoder has run for an hour; and a
// frame's time is the previous frame's plus the real interval between them, AT MOST 1 / fps. So
// the timeline is contiguous: the time a scene stood still (no frames, only keep-alives), and the
// longer intervals of a renderer slower than fps, are left out of it. Real time was tried first:
// in Chromium's Media Source Extensions a fragmented MP4 whose decode time jumps by more than two
// sample durations is a discontinuity, and every frame after it is dropped up to the next key
// frame (a 5 s still scene, then nothing shown for 10 s); a WebM stream played on, but its
// playhead had to play through the still time (each block's duration is taken from the next
// block's timestamp), so it fell 5 s behind the live edge. A recording of the stream (ffmpeg
// -c copy) therefore shows a change right after the still picture before it.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "encode/video.h"

namespace myriad::encode {

// In the order of protocol::kVideoContainers, which names them.
enum class VideoContainer { Myriad, Webm, Mp4 };

std::string_view videoContainerName(VideoContainer container);
// Whether `container` carries `codec`: Myriad and WebM take VP8 and VP9, MP4 takes H264.
bool containerCarries(VideoContainer container, VideoCodec codec);

// One stream's writer: its bytes are the HTTP body, in order. Not thread-safe (one stream's
// worker uses it).
class ContainerWriter {
 public:
  virtual ~ContainerWriter() = default;
  // The bytes of one frame; the first frame's also carry the container's header (WebM: EBML
  // header, Segment, Info, Tracks; MP4: ftyp and moov). `timestampUs` is the encoder's,
  // microseconds since its first frame (non-decreasing). Throws std::invalid_argument when the
  // first frame is not a key frame (or, MP4, has no SPS and PPS) or a timestamp goes back.
  virtual std::string frame(std::span<const uint8_t> packet, bool key, uint64_t timestampUs) = 0;
  // Bytes every reader skips, for an idle stream (only after the first frame).
  virtual std::string keepAlive() const = 0;
};

// A writer for `container` (Webm or Mp4) of `codec` frames of width x height at `fps`. Throws
// std::invalid_argument when the container does not carry the codec, or for Myriad (framed by
// the service).
std::unique_ptr<ContainerWriter> makeContainerWriter(VideoContainer container, VideoCodec codec,
                                                     uint32_t width, uint32_t height, uint32_t fps);

// The NAL units of an Annex B packet (start codes 00 00 01 or 00 00 00 01), without their start
// codes and trailing zero bytes; exposed for tests.
std::vector<std::span<const uint8_t>> annexBNalUnits(std::span<const uint8_t> packet);

}  // namespace myriad::encode
