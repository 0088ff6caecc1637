// GET /v1/sessions/{id}/stream: a multipart/x-mixed-replace response that carries a new frame
// whenever the session changes (or continuously while its lights animate), at most `fps` a second.
// With codec= the same frames go out as video instead (protocol::kVideoStreamContentType): the
// stream joins its session's video channel for that video (SharedFrames: one encoder shared by
// every stream asking for the same target, size, codec, bitrate and fps, freed with the last);
// its first chunk is a key frame; idle re-sends become keep-alive chunks without a picture.
//
// At most two frames in flight per stream: the next frame is rendered from the session's newest
// state after the previous part was written, so a slow client sees fewer, newer frames and
// nothing queues; except that while the lights animate and frames take longer than 1 / fps, the
// next frame is submitted as soon as this one is rendered, before it is encoded, so rendering
// overlaps encoding and writing (an edit then shows one frame later; a stream that ends gives
// that frame up unless it already started). While nothing changes the last part is re-sent every
// kIdleResend, which keeps proxies from timing the connection out and tells a client that just connected what the scene looks like.
// With ?interactive=FPS, frames rendered while the session keeps changing are cheaper (smaller,
// their scale chosen from measured frame times; interactive_quality.h) and marked
// X-Myriad-Interactive, and a full-quality still follows once the session settles.
// A stream ends when the client goes away (seen before each frame is rendered, through PeerWatch,
// or when a write fails), the session closes (deleted or
// expired), or the server shuts down (StreamRegistry::shutdown wakes every waiting stream).
#pragma once

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <list>
#include <string>
#include <string_view>

#include "protocol/constants.h"
#include "encode/video.h"
#include "service/frame_query.h"
#include "service/peer_watch.h"
#include "service/session.h"
#include "service/session_frames.h"

namespace myriad::service {

// The boundary and Content-Type are protocol::kStreamBoundary and protocol::kStreamContentType.
inline constexpr std::chrono::seconds kIdleResend{2};

// The open streams: the maxStreams limit, the myriad_streams gauge, and shutdown.
//
// At the limit, a new stream of a session replaces that session's oldest stream instead of being
// refused: a page that switches target or size opens a new stream and drops the old one, but the
// server learns that the old one's client is gone only at its next write (up to kIdleResend
// later), so a quick succession of switches would otherwise meet 429. Only a session's own
// stream is ever replaced; other sessions still get 429 at the limit.
class StreamRegistry {
 public:
  explicit StreamRegistry(uint32_t maxStreams) : maxStreams_(maxStreams) {}

  // Held by an open stream; releases its place when destroyed.
  class Slot {
   public:
    Slot(StreamRegistry& registry, SessionPtr session);
    ~Slot();
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;

    // A newer stream of the same session took this one's place: end after the current part.
    bool replaced() const { return replaced_.load(); }

   private:
    friend class StreamRegistry;
    StreamRegistry& registry_;
    SessionPtr session_;
    std::atomic<bool> replaced_{false};
  };

  // A place for a stream of `session`, or null when maxStreams streams of other sessions are
  // open or the server is shutting down.
  std::unique_ptr<Slot> open(SessionPtr session);

  uint32_t maxStreams() const { return maxStreams_; }
  uint32_t count() const;  // streams open and not replaced
  bool stopping() const { return stopping_.load(); }

  // Every stream ends after the part it is writing; new ones are refused. Idempotent.
  void shutdown();

 private:
  uint32_t liveCount() const;  // streams not replaced; mutex_ held

  const uint32_t maxStreams_;
  mutable std::mutex mutex_;
  std::list<Slot*> open_;  // oldest first, so shutdown can wake them and a session's oldest is found
  std::atomic<bool> stopping_{false};
};

// The chunked content provider of one stream. `slot` is held until the response is destroyed.
httplib::ContentProviderWithoutLength makeStreamProvider(const SessionFrameContext& context,
                                                         StreamRegistry& registry,
                                                         std::unique_ptr<StreamRegistry::Slot> slot,
                                                         SessionPtr session, FrameRequest request,
                                                         PeerWatch peer);

// A video stream's chunk header (protocol::video_chunk gives the layout).
struct VideoChunk {
  uint8_t kind = 0;  // protocol::video_chunk::kKey, kDelta or kKeepAlive
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t sequence = 0;
  uint64_t timestampUs = 0;
  uint64_t version = 0;
  double time = 0.0;
  uint32_t encodeUs = 0;
};

// One chunk's bytes: the header, then the payload (the frame's bitstream; empty for keep-alive).
std::string videoChunk(const VideoChunk& header, std::string_view payload);

// One part's bytes: headers, image, CRLF and the next boundary line (so a reader that splits on
// boundaries has the part at once). The first part of a stream also carries the opening boundary.
// `interactiveScale` (not empty: an interactive frame) becomes its X-Myriad-Interactive header.
std::string multipartPart(std::string_view contentType, std::string_view image, uint64_t sequence,
                          bool first, std::string_view interactiveScale = {});

}  // namespace myriad::service
