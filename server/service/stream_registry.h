// The open streams (GET .../stream): the server's --max-streams, each session's share of them
// (--max-streams-per-session), the myriad_streams gauge, and shutdown.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <list>
#include <memory>
#include <mutex>

#include "service/peer_watch.h"
#include "service/session.h"

namespace myriad::service {

// A session may hold at most its share of the server's streams, so that one client (or one viewer
// link handed around) cannot take every place: over its share it gets 429 maxStreamsPerSession
// while other sessions still open theirs.
//
// At the server's limit, a new stream of a session replaces that session's oldest stream instead
// of being refused: a page that switches target or size opens a new stream and drops the old one,
// but the server learns that the old one's client is gone only at its next write (up to
// kIdleResend later), so a quick succession of switches would otherwise meet 429. Only a session's
// own stream is ever replaced; other sessions still get 429 at the limit. Before refusing at
// either limit, streams whose client has already hung up (PeerWatch) give their place back.
class StreamRegistry {
 public:
  explicit StreamRegistry(uint32_t maxStreams) : maxStreams_(maxStreams) {}

  // Held by an open stream; releases its place when destroyed.
  class Slot {
   public:
    Slot(StreamRegistry& registry, SessionPtr session, PeerWatch peer);
    ~Slot();
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;

    // This stream's place went to another (a newer stream of its session, or any stream once
    // this one's client was seen gone): end after the current part.
    bool replaced() const { return replaced_.load(); }

   private:
    friend class StreamRegistry;
    StreamRegistry& registry_;
    SessionPtr session_;
    PeerWatch peer_;
    std::atomic<bool> replaced_{false};
  };

  // Why open() gave no place.
  enum class Refusal { none, stopping, maxStreams, maxStreamsPerSession };

  // A place for a stream of `session` whose client is `peer`, or null (and `refusal`, when given,
  // says why) when the server is shutting down, `session` already holds `maxPerSession` streams,
  // or maxStreams streams are open and none of them is this session's.
  std::unique_ptr<Slot> open(SessionPtr session,
                             uint32_t maxPerSession = std::numeric_limits<uint32_t>::max(),
                             PeerWatch peer = {}, Refusal* refusal = nullptr);

  uint32_t maxStreams() const { return maxStreams_; }
  uint32_t count() const;  // streams open and not replaced
  bool stopping() const { return stopping_.load(); }

  // Event streams (GET .../events) server-wide: each holds a worker thread for its life, so they
  // are capped below the workers, beside the frame streams' slots. False when `max` are open.
  bool takeEventPlace(uint32_t max) const {
    uint32_t open = eventStreams_.load();
    while (open < max) {
      if (eventStreams_.compare_exchange_weak(open, open + 1)) return true;
    }
    return false;
  }
  void giveEventPlace() const { eventStreams_.fetch_sub(1); }

  // Every stream ends after the part it is writing; new ones are refused. Idempotent.
  void shutdown();

 private:
  // mutex_ held for all three.
  uint32_t liveCount() const;  // streams not replaced
  uint32_t liveCount(const SessionPtr& session) const;
  void reclaimGone();  // replaces the streams whose client hung up

  const uint32_t maxStreams_;
  mutable std::atomic<uint32_t> eventStreams_{0};
  mutable std::mutex mutex_;
  // Oldest first, so shutdown can wake them and a session's oldest is found.
  std::list<Slot*> open_;
  std::atomic<bool> stopping_{false};
};

}  // namespace myriad::service
