// One pool of encoder threads for the whole server, shared by every session's video streams, with
// fair turns between sessions (docs/ARCHITECTURE.md, "Encoder pool").
//
// Why a pool: before it, every video channel encoded on the HTTP worker of whichever stream made
// its frame, with libvpx's own threads besides (4 per encoder). N sessions meant N encodes at once
// and 4N encoder threads on a host of C cores; at 16 sessions on 16 cores every stream fell to a
// third of its rate together, and nothing stopped one session with several streams (or a 4K one)
// from taking most of the CPU. With the pool, encodes run on `threads` pool threads (default:
// the host's hardware threads) and an encode holds as many of the pool's cores as its encoder has
// threads while it runs, so the encoders never ask for more cores than the pool has; an HTTP
// worker hands its frame over and waits.
//
// Fair turns: start-time fair queueing by tenant (a session). Each tenant has a virtual time, the
// core-seconds its encodes have taken; a free core goes to the waiting encode of the tenant with
// the smallest virtual time. A tenant that was idle comes back at the pool's current virtual time
// (an idle tenant saves no credit). A job is charged its tenant's estimated cost when it starts
// (so one tenant's queued jobs do not all start at once on its old virtual time) and corrected by
// the measured cost when it ends. So a session with four streams, or with 4K frames, gets the
// same CPU share as a session with one small stream while both wait; a light session's frame
// never waits behind more than one encode of each other session.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "encode/video.h"

namespace myriad::encode {

// The threads an encoder of `codec` at width x height gets (libvpx row-mt and tile columns,
// OpenH264 slices) on a pool of `poolThreads` that already holds `liveEncoders` encoders:
// one thread per 960x540 of picture (an encode of about 5 ms on one core of the H200 host at
// speed 8), at most the pool's share per live encoder (the pool's cores divided among the
// encoders, so many sessions get single-threaded encoders, which waste nothing on
// synchronisation), at most a quarter of the pool and 8. The same for VP8, whose libvpx threads
// spin-wait on each other (measured 17x slower than one thread on busy cores): the pool never
// runs more encoder threads than it has cores, and many encoders get one thread each.
uint32_t encoderThreadsFor(VideoCodec codec, uint32_t width, uint32_t height,
                           uint32_t poolThreads, uint32_t liveEncoders);

class EncodePool {
 public:
  using Clock = std::chrono::steady_clock;

  // `threads` 0: std::thread::hardware_concurrency() (at least 1).
  explicit EncodePool(uint32_t threads);
  ~EncodePool();  // runs what is queued, then joins
  EncodePool(const EncodePool&) = delete;
  EncodePool& operator=(const EncodePool&) = delete;

  uint32_t threads() const { return threads_; }

  // Runs `job` on a pool thread in `tenant`'s turn, holding `cores` (clamped to 1..threads()) of
  // the pool's cores while it runs, and returns when it finished; rethrows what `job` threw.
  // Called from any thread but the pool's own.
  void run(std::string_view tenant, uint32_t cores, const std::function<void()>& job);

  // Upper bounds of myriad_encode_seconds' buckets (+Inf implicit): a 160x90 VP9 frame on a busy
  // core takes about a millisecond, 4K on one core of the 2-core container several hundred.
  static constexpr std::array<double, 12> kBuckets = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02,
                                                      0.04,   0.08,  0.16,  0.32,  0.64, 1.28};
  struct Stats {
    uint32_t threads = 0;
    uint32_t queued = 0;   // jobs waiting for their turn (the queue depth)
    uint32_t running = 0;  // jobs running
    uint32_t tenants = 0;  // tenants known (waiting, running, or recently served)
    uint64_t jobs = 0;     // jobs finished
    std::array<uint64_t, kBuckets.size()> buckets{};  // job run times, not cumulative
    double secondsSum = 0.0;      // run time of every finished job
    double waitSecondsSum = 0.0;  // time they waited for their turn
  };
  Stats stats() const;

  // How many jobs of `tenant` have finished (tests: who got the turns).
  uint64_t jobsOf(std::string_view tenant) const;

 private:
  struct Job {
    const std::function<void()>* work = nullptr;
    uint32_t cores = 1;
    Clock::time_point queuedAt;
    std::promise<void> done;
  };
  struct Tenant {
    std::deque<Job*> waiting;
    uint32_t running = 0;
    double vtime = 0.0;         // core-seconds charged (estimates of running jobs included)
    double estimate = 0.005;    // the cost charged when a job starts: the mean of the last ones
    uint64_t jobs = 0;
    Clock::time_point lastUsed{};
  };

  void work();  // a pool thread
  // The tenant whose waiting job runs next, or null when none may start now. mutex_ held.
  Tenant* pick();
  void dropIdle(Clock::time_point now);  // mutex_ held

  const uint32_t threads_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::map<std::string, Tenant, std::less<>> tenants_;
  double vclock_ = 0.0;  // the virtual time of the last job started
  uint32_t coresInUse_ = 0;
  uint32_t queued_ = 0;
  uint32_t running_ = 0;
  uint64_t jobs_ = 0;
  std::array<uint64_t, kBuckets.size()> buckets_{};
  double secondsSum_ = 0.0;
  double waitSecondsSum_ = 0.0;
  std::vector<std::thread> workers_;
};

}  // namespace myriad::encode
