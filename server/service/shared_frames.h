// Streams of one session that ask for the same picture (target, size, format, quality) share one
// render and one encode: several viewers of a session cost the server what one does.
//
// Each (session, picture) has one entry: the newest frame rendered for it, the session version it
// shows and when it was rendered, and whether a stream is rendering it now. A stream that wants a
// frame takes the entry's frame when it is one it has not sent, shows the session's current version
// and, while lights animate, is younger than the stream's frame interval; when another stream is
// rendering it, it waits for that frame instead of queueing its own; otherwise it renders, and the
// others take what it made. So N streams of one session at one fps make as many renders as one
// stream (GET .../stats "frames" and myriad_frame_seconds_count count them).
//
// Video streams (codec=) of one session that ask for the same picture and encoding (target, size,
// codec, bitrate, fps) share a channel: one render and ONE encoder for all of them, whose chunks
// every viewer of the channel gets. A delta chunk decodes only after every chunk since the key
// frame before it, so a channel keeps a log of its newest chunks (at most kMaxVideoBacklog + 1,
// and kMaxVideoLogBytes) and each viewer its position in it (the generation it sent last):
//   - a viewer that wants a frame gets every chunk after its position, when its position is still
//     in the log and it is at most kMaxVideoBacklog (max(8, fps): about a second) behind;
//   - a viewer that just joined, or fell further behind (a slow client: its worker was blocked
//     writing), gets the log from its first chunk when that is a key frame and the log is short
//     (kMaxVideoReplay chunks); otherwise it asks the channel for a key frame (the next encode is
//     forced to be one) and skips every chunk until that key frame. So a slow viewer never holds
//     the others back, and costs memory only through the log, which is bounded.
// Rate adaptation (per channel, bounded steps): a viewer that falls behind (not a joiner) lowers
// the channel's bitrate to 3/4 (at most one step a second, never below 1/4 of the asked bitrate):
// its link did not carry what the encoder made; a viewer whose client is behind (stream.h,
// "Delivery") caps it at once to 85% of the rate its link was measured to take
// (capVideoBitrate), so a cap that falls from 10 to 3 Mbit/s is followed within a second, not in
// 3/4 steps. Every kVideoRaiseAfter without a step (down or
// up), the next encode raises it by 5/4, up to the asked bitrate. One encoder serves every viewer, so the
// slowest viewer's link sets the quality for all of them (no per-viewer layers).
// As for images, a viewer takes the newest chunk when it is newer than its position, shows the
// session's current version and (animating) is younger than the stream's interval; when another
// viewer is rendering and encoding, it waits for that chunk; otherwise it renders and encodes.
// Channels go with their last viewer (the encoder with them).
//
// Encodes run on the server's encoder pool (encode/encode_pool.h) when one is given: the viewer
// that makes a channel's frame hands the encode to the pool, in its session's fair turn, and
// waits; the encoder's threads (libvpx row-mt and tiles, OpenH264 slices) are chosen when the
// channel opens from the pool's size and the encoders already open (encode::encoderThreadsFor).
// Without a pool (unit tests, a stream without shared frames) the viewer encodes itself.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "encode/encode_pool.h"
#include "encode/video.h"

#include "service/frame_query.h"
#include "service/session.h"
#include "service/session_frames.h"

namespace myriad::service {

class SharedFrames {
 public:
  SharedFrames() = default;
  // Video channels encode on `pool` (null: on the viewer's own thread); it must outlive them.
  explicit SharedFrames(encode::EncodePool* pool) : pool_(pool) {}
  // Rate adaptation's periods other than kVideoRaiseAfter and kVideoLowerEvery (tests).
  SharedFrames(Clock::duration videoRaiseAfter, Clock::duration videoLowerEvery)
      : videoRaiseAfter_(videoRaiseAfter), videoLowerEvery_(videoLowerEvery) {}

  // A frame as the streams share it: bytes, the session version it shows, and its generation in
  // its entry (a stream sends a generation once).
  struct Frame {
    std::shared_ptr<const EncodedFrame> encoded;
    uint64_t version = 0;
    uint64_t generation = 0;
    Clock::duration took{};  // how long its render and encode took
  };

  // A frame of `session` as `request` asks, other than generation `shown`: shared when a fitting
  // one exists or is being made, else rendered here (renderSessionFrame). `maxAge` bounds how old
  // a shared frame of an animating session may be (the stream's frame interval). Throws what
  // renderSessionFrame throws.
  Frame next(const SessionFrameContext& context, const SessionPtr& session,
             const FrameRequest& request, uint64_t shown, Clock::duration maxAge);

  // Frames handed to a stream that another stream rendered (myriad_stream_frames_shared_total).
  uint64_t sharedCount() const;

  // ---- Video channels.

  // One encoded frame of a channel as every viewer gets it (the stream adds its own sequence).
  struct VideoFrame {
    uint64_t generation = 0;  // 1, 2, ... in its channel
    bool key = false;
    std::string payload;  // the codec's bitstream of the frame
    uint32_t width = 0;
    uint32_t height = 0;
    uint64_t timestampUs = 0;  // since the channel's first frame
    uint64_t version = 0;      // the session version it shows
    double time = 0.0;         // the animation time it shows
    uint32_t encodeUs = 0;
    Clock::time_point renderedAt{};
  };
  using VideoFramePtr = std::shared_ptr<const VideoFrame>;
  class VideoChannel;

  // A video stream's place in its channel: made by joinVideo, released with the stream.
  struct VideoViewer {
    std::shared_ptr<VideoChannel> channel;
    uint64_t position = 0;  // the generation sent last (0: none yet)
    uint64_t resyncs = 0;   // times it was too far behind and skipped to a key frame
    bool skipping = false;  // waiting for a key frame (joined late or fell behind)
  };

  // Joins (or opens) the channel of `session` for `request` (request.video set) with `settings`'
  // encoder, which the channel's first encode makes (ChannelEncoder).
  VideoViewer joinVideo(const SessionPtr& session, const FrameRequest& request,
                        const encode::VideoSettings& settings);

  // The chunks `viewer` sends next, oldest first, never empty; its position moves to the last.
  // Renders and encodes one frame when no fitting chunk exists or is being made. Throws what
  // renderSessionFrame throws and encode::VideoError.
  // `gone` (when given) says whether the viewer's client has left: a frame rendered for a
  // viewer alone in its channel whose client left meanwhile is not encoded (no encoder is made
  // for nobody); ViewerGone is thrown instead.
  std::vector<VideoFramePtr> nextVideo(const SessionFrameContext& context,
                                       const SessionPtr& session, const FrameRequest& request,
                                       VideoViewer& viewer, Clock::duration maxAge,
                                       const std::function<bool()>& gone = {});
  struct ViewerGone : std::runtime_error {
    ViewerGone() : std::runtime_error("the video stream's client left") {}
  };

  // `viewer`'s client is behind and its link took `kbps` meanwhile (stream.h, "Delivery"): the
  // channel's bitrate drops to 85% of it at once (room for the stream's framing and the link's
  // other traffic) when that is below the channel's current target; never below a quarter of
  // the asked bitrate, and it climbs back as after any step down.
  void capVideoBitrate(VideoViewer& viewer, uint32_t kbps);

  uint64_t videoEncodeCount() const;   // frames encoded by channels (myriad_video_encodes_total)
  uint64_t videoResyncCount() const;   // viewers that skipped to a key frame (myriad_video_resyncs_total)
  uint32_t videoChannelCount() const;  // channels open now (myriad_video_encoders)
  // Encoders made and freed since the start (myriad_video_encoders_created_total / _freed_total):
  // made - freed is the encoders alive, those of channels whose last viewer is gone included
  // until the channel's last reference goes.
  uint64_t videoEncodersCreated() const { return encoderCounts_->created.load(); }
  uint64_t videoEncodersFreed() const { return encoderCounts_->freed.load(); }
  encode::EncodePool* pool() const { return pool_; }

  // Counts shared with every channel, which may outlive the SharedFrames that made it (a
  // stream's own SharedFrames goes before its channel).
  struct EncoderCounts {
    std::atomic<uint64_t> created{0};
    std::atomic<uint64_t> freed{0};
  };

  // A viewer's bounds (see the top of this file).
  static constexpr size_t kMaxVideoReplay = 4;
  static constexpr size_t kMaxVideoLogBytes = size_t(32) << 20;
  static size_t maxVideoBacklog(uint32_t fps) { return std::max<size_t>(8, fps); }
  static constexpr std::chrono::seconds kVideoRaiseAfter{10};
  static constexpr std::chrono::seconds kVideoLowerEvery{1};

 private:
  struct Entry {
    std::weak_ptr<Session> session;
    bool rendering = false;
    uint64_t generation = 0;
    uint64_t version = 0;
    Clock::time_point renderedAt{};
    Clock::time_point usedAt{};
    Clock::duration took{};
    std::shared_ptr<const EncodedFrame> encoded;
  };
  static std::string keyOf(const Session& session, const FrameRequest& request);
  void dropStale(Clock::time_point now);  // mutex_ held

  static std::string videoKeyOf(const Session& session, const FrameRequest& request,
                                const encode::VideoSettings& settings);
  // The chunks `viewer` may take now, or empty when it must wait for a key frame. mutex_ held.
  // `viewer` must skip to a key frame: the next encode makes one; a viewer that had frames
  // (not a joiner) counts as a resync and steps the bitrate down. mutex_ held.
  void wantKey(VideoChannel& channel, VideoViewer& viewer, Clock::time_point now);
  static std::vector<VideoFramePtr> sliceFor(const VideoChannel& channel, uint64_t position,
                                             size_t backlog);

  mutable std::mutex mutex_;
  std::condition_variable rendered_;  // an entry's render finished (or failed)
  std::map<std::string, Entry, std::less<>> entries_;
  uint64_t shared_ = 0;
  uint64_t generations_ = 0;  // every entry's generations from one count: never one twice
  std::map<std::string, std::weak_ptr<VideoChannel>, std::less<>> channels_;
  uint64_t videoEncodes_ = 0;
  uint64_t videoResyncs_ = 0;
  Clock::duration videoRaiseAfter_ = kVideoRaiseAfter;
  Clock::duration videoLowerEvery_ = kVideoLowerEvery;
  encode::EncodePool* pool_ = nullptr;
  std::shared_ptr<EncoderCounts> encoderCounts_ = std::make_shared<EncoderCounts>();
};

// A channel's encoder, made by its first encode rather than when the channel opens: libvpx's
// VP9 encoder takes about 9 MiB even at 160x96 (more with the size), and a stream whose client
// left before its first frame (a page switching size, a client opening and dropping streams)
// then never costs one. settings() and setBitrate() work before it exists.
class ChannelEncoder {
 public:
  explicit ChannelEncoder(const encode::VideoSettings& settings) : settings_(settings) {}
  // Makes the encoder first when there is none (`made` is told); throws what VideoEncoder does.
  encode::VideoPacket encode(std::span<const uint8_t> rgba, uint64_t timestampMs, bool forceKey,
                             const std::function<void()>& made) {
    if (!encoder_) {
      encoder_.emplace(settings_);
      made();
    }
    return encoder_->encode(rgba, timestampMs, forceKey);
  }
  void setBitrate(uint32_t kbps) {
    if (encoder_) encoder_->setBitrate(kbps);
    settings_.bitrateKbps = kbps;
  }
  const encode::VideoSettings& settings() const { return settings_; }
  bool made() const { return encoder_.has_value(); }

 private:
  encode::VideoSettings settings_;
  std::optional<encode::VideoEncoder> encoder_;
};

class SharedFrames::VideoChannel {
 public:
  VideoChannel(std::string key, const encode::VideoSettings& settings,
               std::shared_ptr<EncoderCounts> counts)
      : freed_(std::move(counts)), key(std::move(key)), encoder(settings),
        askedKbps(settings.bitrateKbps), targetKbps(settings.bitrateKbps) {}

  // The encoder's next packet, its encoder made first when this is the channel's first encode.
  encode::VideoPacket encode(std::span<const uint8_t> rgba, uint64_t timestampMs, bool forceKey) {
    return encoder.encode(rgba, timestampMs, forceKey, [this] {
      freed_.counts->created.fetch_add(1);  // after the encoder: one that threw was never made
      freed_.made = true;
    });
  }
  VideoChannel(const VideoChannel&) = delete;
  VideoChannel& operator=(const VideoChannel&) = delete;

 private:
  // Destroyed after every other member, the encoder included: counts it freed and gives the
  // memory the encoder freed back to the system (shared_frames.cpp says why).
  struct FreedNotice {
    std::shared_ptr<EncoderCounts> counts;
    bool made = false;
    ~FreedNotice();
  };
  FreedNotice freed_;

 public:
  const std::string key;
  ChannelEncoder encoder;  // used only by the viewer rendering (one at a time)
  const Clock::time_point startedAt = Clock::now();
  // Guarded by SharedFrames::mutex_:
  bool rendering = false;
  bool keyWanted = false;  // a viewer waits for a key frame: the next encode makes one
  uint64_t generations = 0;
  std::deque<VideoFramePtr> log;  // the newest frames, oldest first
  size_t logBytes = 0;
  const uint32_t askedKbps;          // the streams' bitrate
  uint32_t targetKbps;               // the rate adaptation's, applied by the next encode
  Clock::time_point lastStep{};      // the last bitrate step (down or up)
  Clock::time_point lastDown{};      // the last step down
};

}  // namespace myriad::service
