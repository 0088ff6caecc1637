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
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "service/frame_query.h"
#include "service/session.h"
#include "service/session_frames.h"

namespace myriad::service {

class SharedFrames {
 public:
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

  mutable std::mutex mutex_;
  std::condition_variable rendered_;  // an entry's render finished (or failed)
  std::map<std::string, Entry, std::less<>> entries_;
  uint64_t shared_ = 0;
  uint64_t generations_ = 0;  // every entry's generations from one count: never one twice
};

}  // namespace myriad::service
