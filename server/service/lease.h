// The leases this node holds: one per session it serves (state_store.h has the store's side).
//
// A node serves a session only while it holds the session's lease at the epoch its copy was
// made under. It takes the lease when it creates or restores the session (acquire), renews all it
// holds every quarter of the lease time on a thread of its own (one store call for all of them),
// and gives a lease back when it closes the session (idle expiry, shutdown). A lease it no longer
// holds (taken over by a node that found it expired, a session deleted elsewhere) is lost: the
// copy here is closed (`onLost`), and the session's next request here restores it from the store
// or is told which node owns it now.
//
// Between renewals a lease counts as held until 80% of its time has passed since the renewal was
// sent; past that, holds() asks the store before the copy serves anything. A node that was
// stopped (SIGSTOP) for longer than the lease time thus finds its leases lapsed on waking, and
// any write it still had in flight is refused by the store (its epoch is no longer the lease's).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "service/state_store.h"

namespace myriad::service {

class LeaseKeeper {
 public:
  using Lost = std::function<void(const std::string& id, uint64_t epoch)>;
  LeaseKeeper(StateStore& store, uint32_t node, std::chrono::milliseconds ttl, Lost onLost);
  ~LeaseKeeper();  // stops renewing and gives back every lease held
  LeaseKeeper(const LeaseKeeper&) = delete;
  LeaseKeeper& operator=(const LeaseKeeper&) = delete;

  uint32_t node() const { return node_; }
  std::chrono::milliseconds ttl() const { return ttl_; }

  // Takes the lease of a session about to be served here and returns its epoch. The session's
  // home node (the node its id names, where fronts route it) asks a live owner to hand it over:
  // the owner closes its copy and releases the lease at its next renewal (a quarter of the lease
  // time), so a session goes home when its node returns, nothing is served by two nodes, and
  // since only the home node asks, two nodes never pass a session back and forth. Another node
  // waits once for a live lease's remaining time (a crashed owner's sessions are served here as
  // soon as its leases lapse). Throws ProblemError: 409 naming the owner (its lease is live: send the request
  // there), 503 when the store cannot be reached. `fresh`: a session just created.
  uint64_t acquire(std::string_view id, bool fresh);
  // Whether this node still holds the lease of `id` at `epoch`: known from the last renewal, or
  // asked of the store now. False when the store cannot be reached and the lease may have lapsed.
  bool holds(std::string_view id, uint64_t epoch);
  // The session was closed here: its lease is given back (another node may take it at once).
  void release(std::string_view id, uint64_t epoch);
  // The lease is another's now (a fenced write): forgotten here, not given back.
  void dropped(std::string_view id, uint64_t epoch);

  // Prometheus series (myriad_lease_*), each labelled `labels` ("node=\"1\"" or "").
  std::string exposition(std::string_view labels) const;

  // Counted by the session code (session_sync.cpp).
  std::atomic<uint64_t> fencedWrites{0};   // writes the store refused for a stale epoch/version
  std::atomic<uint64_t> failedWrites{0};   // writes that did not reach the store
  std::atomic<uint64_t> takeovers{0};      // restores of a session another node had leased

 private:
  struct Held {
    uint64_t epoch = 0;
    std::chrono::steady_clock::time_point validUntil;
  };
  void loop();
  std::chrono::steady_clock::time_point validFrom(std::chrono::steady_clock::time_point sent) const;

  StateStore& store_;
  const uint32_t node_;
  const std::chrono::milliseconds ttl_;
  const Lost onLost_;
  mutable std::mutex mutex_;  // guards held_ and stopping_
  std::map<std::string, Held, std::less<>> held_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::atomic<uint64_t> acquired_{0};
  std::atomic<uint64_t> refused_{0};        // 409: another node's live lease
  std::atomic<uint64_t> lost_{0};
  std::atomic<uint64_t> handovers_{0};
  std::atomic<uint64_t> renewFailures_{0};
  std::atomic<uint64_t> maxEpoch_{0};
  std::thread thread_;
};

// The owner a 409 of acquire() named on this thread, once (the response's X-Myriad-Owner header,
// which a front follows); nullopt when none.
std::optional<uint32_t> takeOwnerHint();

}  // namespace myriad::service
