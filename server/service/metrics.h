// GET /metrics: counters and a histogram kept by the HTTP layer, written out in the Prometheus
// text exposition format 0.0.4. Thread-safe; no HTTP, no Vulkan.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

namespace myriad::service {

// Values the exposition reads from elsewhere at scrape time.
struct MetricGauges {
  uint64_t sessions = 0;
  uint64_t streams = 0;
  uint64_t gpuMemoryBytes = 0;
  uint64_t validationMessages = 0;
  uint64_t sharedStreamFrames = 0;  // stream parts another stream's render made (SharedFrames)
  uint64_t videoEncodes = 0;        // frames encoded by video streams' shared encoders
  uint64_t videoEncoders = 0;       // video stream encoders open now (one per channel)
  uint64_t videoResyncs = 0;        // video viewers that fell behind and skipped to a key frame
  uint64_t videoEncodersCreated = 0;  // video encoders made since the start
  uint64_t videoEncodersFreed = 0;    // and freed (made - freed: alive now)
  // The encoder pool (encode/encode_pool.h): threads, jobs waiting and running, and how long
  // each job ran (buckets of encodeBuckets, not cumulative) and waited for its turn.
  uint64_t encodeThreads = 0;
  uint64_t encodeQueued = 0;
  uint64_t encodeRunning = 0;
  std::array<double, 12> encodeBuckets{};
  std::array<uint64_t, 12> encodeBucketCounts{};
  uint64_t encodeJobs = 0;
  double encodeSecondsSum = 0.0;
  double encodeWaitSecondsSum = 0.0;
  // The connection layer (service/http_connections.h) and the memory budget.
  uint64_t connectionsOpen = 0;
  uint64_t connectionsAccepted = 0;
  uint64_t connectionsRefused = 0;   // 503 at a cap, nothing waiting to give way
  uint64_t connectionsEvicted = 0;   // waiting ones closed for newer ones at a cap
  uint64_t headTimeouts = 0;         // 408
  uint64_t headsRefused = 0;         // 400, 414, 431, 501, 505 before any handler
  uint64_t memoryReservedBytes = 0;
  uint64_t memoryLimitBytes = 0;
};

class Metrics {
 public:
  // Upper bounds of myriad_frame_seconds' buckets (+Inf is implicit). A 64x64 frame on a GPU takes
  // about a millisecond, a 4K frame on lavapipe with validation several seconds.
  static constexpr std::array<double, 12> kFrameBuckets = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                           0.5,   1.0,  2.5,   5.0,  10.0, 30.0};

  // `routeTemplate` is the route's path template ("/v1/sessions/{id}/frame"), never the raw path:
  // a label per session id or per mistyped URL would grow the exposition without bound.
  void countRequest(std::string_view routeTemplate, int status);

  // One frame delivered: from submission to the renderer to encoded bytes.
  void observeFrame(double seconds);
  // And how long it waited before its work began (render::Frame::queueMs: behind other frames'
  // submissions included), the same buckets.
  void observeQueueWait(double seconds);

  // The text/plain; version=0.0.4 body.
  std::string exposition(const MetricGauges& gauges) const;

  // A label every series carries (--node-id: node="N"), so that the series of several servers
  // scraped through one front stay apart. Set before serving.
  void setNodeLabel(std::string node) { node_ = std::move(node); }
  // More series from elsewhere (the lease series, service/lease.h), appended to every exposition
  // without labels (the node label is added to them too). Set before serving.
  void setExtraSeries(std::function<std::string()> extra) { extra_ = std::move(extra); }

  // The count so far for one route and status (tests and logs).
  uint64_t requests(std::string_view routeTemplate, int status) const;

 private:
  std::string node_;  // "" = no node label
  std::function<std::string()> extra_;
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, int>, uint64_t> requests_;
  std::array<uint64_t, kFrameBuckets.size()> frameBucketCounts_{};  // not cumulative
  uint64_t frameCount_ = 0;
  double frameSecondsSum_ = 0.0;
  std::array<uint64_t, kFrameBuckets.size()> queueBucketCounts_{};  // not cumulative
  uint64_t queueCount_ = 0;
  double queueSecondsSum_ = 0.0;
};

// Served as protocol::kMetricsContentType.

}  // namespace myriad::service
