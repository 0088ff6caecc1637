// The encoder pool (encode/encode_pool.h): jobs run on its threads, never more cores in use
// than it has, errors come back to the caller, and turns are fair between tenants: a tenant
// whose jobs are heavy, or who has many callers, does not starve one with light jobs.
#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "encode/encode_pool.h"

using namespace myriad::encode;
using namespace std::chrono_literals;

namespace {

// Busy for `d` (a CPU-bound encode's stand-in; sleeping would do for the pool's accounting, but
// the pool measures run time, and either is fine).
void busyFor(std::chrono::steady_clock::duration d) {
  const auto until = std::chrono::steady_clock::now() + d;
  while (std::chrono::steady_clock::now() < until) {
  }
}

}  // namespace

TEST_CASE("encode pool: jobs run on the pool's threads, errors come back, stats count") {
  EncodePool pool(2);
  CHECK(pool.threads() == 2);
  const std::thread::id caller = std::this_thread::get_id();
  std::thread::id ran;
  pool.run("a", 1, [&] { ran = std::this_thread::get_id(); });
  CHECK(ran != caller);
  CHECK_THROWS_WITH_AS(pool.run("a", 1, [] { throw std::runtime_error("bad frame"); }),
                       "bad frame", std::runtime_error);
  const EncodePool::Stats s = pool.stats();
  CHECK(s.jobs == 2);
  CHECK(s.queued == 0);
  CHECK(s.running == 0);
  uint64_t bucketed = 0;
  for (uint64_t b : s.buckets) bucketed += b;
  CHECK(bucketed == 2);
  CHECK(pool.jobsOf("a") == 2);
  CHECK(EncodePool(0).threads() >= 1);  // 0: the host's
}

TEST_CASE("encode pool: never more cores in use than it has") {
  EncodePool pool(4);
  std::atomic<int> cores{0};
  std::atomic<int> most{0};
  auto job = [&](int weight) {
    return [&, weight] {
      const int now = cores.fetch_add(weight) + weight;
      int seen = most.load();
      while (now > seen && !most.compare_exchange_weak(seen, now)) {
      }
      std::this_thread::sleep_for(5ms);
      cores.fetch_sub(weight);
    };
  };
  std::vector<std::thread> callers;
  for (int i = 0; i < 12; ++i) {
    const int weight = 1 + i % 3;  // 1, 2, 3 cores
    callers.emplace_back([&, weight, i] {
      for (int k = 0; k < 5; ++k) pool.run("t" + std::to_string(i % 4), weight, job(weight));
    });
  }
  for (std::thread& t : callers) t.join();
  CHECK(most.load() <= 4);
  CHECK(most.load() >= 2);  // and it did run jobs side by side
  CHECK(pool.stats().jobs == 60);
}

TEST_CASE("encode pool: a light tenant gets its turns beside heavy ones") {
  // One pool thread; a heavy tenant with four callers each submitting 8 ms jobs back to back,
  // and a light tenant with one caller submitting 1 ms jobs. First come, first served would
  // give the light tenant one turn in five (each of its jobs behind four heavy ones: 33 ms a
  // turn, about 30 in a second); fair by time it waits for at most one heavy job (9 ms a turn,
  // about 100 in a second, measured 104 light against 108 heavy on the idle 2-core container).
  EncodePool pool(1);
  std::atomic<bool> stop{false};
  std::vector<std::thread> heavy;
  for (int i = 0; i < 4; ++i) {
    heavy.emplace_back([&] {
      while (!stop) pool.run("heavy", 1, [] { busyFor(8ms); });
    });
  }
  std::this_thread::sleep_for(50ms);  // the heavy tenant's queue is full
  const uint64_t heavyBefore = pool.jobsOf("heavy");
  const auto start = std::chrono::steady_clock::now();
  uint64_t light = 0;
  while (std::chrono::steady_clock::now() - start < 1s) {
    pool.run("light", 1, [] { busyFor(1ms); });
    ++light;
  }
  stop = true;
  for (std::thread& t : heavy) t.join();
  const uint64_t heavyDuring = pool.jobsOf("heavy") - heavyBefore;
  MESSAGE("in 1 s on one thread: light tenant " << light << " jobs of 1 ms, heavy tenant "
                                                << heavyDuring << " jobs of 8 ms");
  // Fair by time: the light tenant waits for at most one heavy job per turn, so it gets about
  // as many turns as the heavy one (first come, first served: a quarter as many). As a ratio:
  // a busy machine stretches both alike.
  CHECK(light * 2 >= heavyDuring);
  // And the heavy tenant is not starved either: it gets the time the light one does not use.
  CHECK(heavyDuring * 4 >= light);
  CHECK(heavyDuring >= 10);
}

TEST_CASE("encode pool: encoder threads from the size and the pool") {
  // 1080p on the 16-core host: 4 threads (a quarter of the pool); on 2 cores: 1.
  CHECK(encoderThreadsFor(VideoCodec::Vp9, 1920, 1080, 16, 0) == 4);
  CHECK(encoderThreadsFor(VideoCodec::Vp9, 1920, 1080, 2, 0) == 1);
  // Small pictures: one thread whatever the pool.
  CHECK(encoderThreadsFor(VideoCodec::H264, 640, 360, 64, 0) == 1);
  // 4K on 64 cores: one per 960x540, at most 8.
  CHECK(encoderThreadsFor(VideoCodec::Vp9, 3840, 2160, 64, 0) == 8);
  // Many encoders share the pool: 16 open on 16 cores get one thread each.
  CHECK(encoderThreadsFor(VideoCodec::H264, 1920, 1080, 16, 15) == 1);
  CHECK(encoderThreadsFor(VideoCodec::Vp8, 1920, 1080, 16, 3) == 4);
}
