#include "service/metrics.h"

#include <charconv>
#include <cmath>

namespace myriad::service {
namespace {

// Label values are quoted; the format requires backslash, quote and newline escaped.
std::string labelValue(std::string_view text) {
  std::string out;
  for (char c : text) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}

// Shortest text that reads back as the same double; Prometheus accepts any float syntax.
std::string number(double value) {
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  char buffer[32];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return ec == std::errc() ? std::string(buffer, end) : "NaN";
}

void family(std::string& out, std::string_view name, std::string_view type,
            std::string_view help) {
  out += "# HELP " + std::string(name) + " " + std::string(help) + "\n";
  out += "# TYPE " + std::string(name) + " " + std::string(type) + "\n";
}

// A family of one unlabelled sample.
void single(std::string& out, std::string_view name, std::string_view type, std::string_view help,
            uint64_t value) {
  family(out, name, type, help);
  out += std::string(name) + " " + std::to_string(value) + "\n";
}
void single(std::string& out, std::string_view name, std::string_view type, std::string_view help,
            double value) {
  family(out, name, type, help);
  out += std::string(name) + " " + number(value) + "\n";
}

}  // namespace

void Metrics::countRequest(std::string_view routeTemplate, int status) {
  std::lock_guard lock(mutex_);
  ++requests_[{std::string(routeTemplate), status}];
}

namespace {

// Adds one observation to a histogram of Metrics::kFrameBuckets.
void observe(std::array<uint64_t, Metrics::kFrameBuckets.size()>& buckets, uint64_t& count,
             double& sum, double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) seconds = 0.0;
  for (size_t i = 0; i < Metrics::kFrameBuckets.size(); ++i) {
    if (seconds <= Metrics::kFrameBuckets[i]) {
      ++buckets[i];
      break;
    }
  }
  ++count;
  sum += seconds;
}

// A histogram of `bounds` (Metrics::kFrameBuckets unless given) in the exposition format.
void histogram(std::string& out, std::string_view name,
               const std::array<uint64_t, Metrics::kFrameBuckets.size()>& buckets,
               uint64_t count, double sum,
               const std::array<double, Metrics::kFrameBuckets.size()>& bounds =
                   Metrics::kFrameBuckets) {
  uint64_t cumulative = 0;
  for (size_t i = 0; i < bounds.size(); ++i) {
    cumulative += buckets[i];
    out += std::string(name) + "_bucket{le=\"" + number(bounds[i]) + "\"} " +
           std::to_string(cumulative) + "\n";
  }
  out += std::string(name) + "_bucket{le=\"+Inf\"} " + std::to_string(count) + "\n";
  out += std::string(name) + "_sum " + number(sum) + "\n";
  out += std::string(name) + "_count " + std::to_string(count) + "\n";
}

}  // namespace

void Metrics::observeFrame(double seconds) {
  std::lock_guard lock(mutex_);
  observe(frameBucketCounts_, frameCount_, frameSecondsSum_, seconds);
}

void Metrics::observeQueueWait(double seconds) {
  std::lock_guard lock(mutex_);
  observe(queueBucketCounts_, queueCount_, queueSecondsSum_, seconds);
}

uint64_t Metrics::requests(std::string_view routeTemplate, int status) const {
  std::lock_guard lock(mutex_);
  auto it = requests_.find({std::string(routeTemplate), status});
  return it == requests_.end() ? 0 : it->second;
}

namespace {

// `exposition` with name="value" added to every sample line (comments untouched): first among
// a series' labels, or as its only label.
std::string withLabel(std::string_view exposition, std::string_view name, std::string_view value) {
  const std::string label = std::string(name) + "=\"" + labelValue(value) + "\"";
  std::string out;
  out.reserve(exposition.size() + exposition.size() / 8);
  size_t start = 0;
  while (start < exposition.size()) {
    size_t end = exposition.find('\n', start);
    if (end == std::string_view::npos) end = exposition.size();
    std::string_view line = exposition.substr(start, end - start);
    if (line.empty() || line.front() == '#') {
      out += line;
    } else {
      const size_t split = line.find_first_of("{ ");
      out += line.substr(0, split);
      if (split != std::string_view::npos && line[split] == '{') {
        out += "{" + label + (line[split + 1] == '}' ? "" : ",");
        out += line.substr(split + 1);
      } else {
        out += "{" + label + "}";
        if (split != std::string_view::npos) out += line.substr(split);
      }
    }
    if (end < exposition.size()) out += '\n';
    start = end + 1;
  }
  return out;
}

}  // namespace

std::string Metrics::exposition(const MetricGauges& gauges) const {
  std::string out;
  std::lock_guard lock(mutex_);

  family(out, "myriad_http_requests_total", "counter",
         "HTTP responses sent, by route template and status code.");
  for (const auto& [key, count] : requests_) {
    out += "myriad_http_requests_total{route=\"" + labelValue(key.first) + "\",status=\"" +
           std::to_string(key.second) + "\"} " + std::to_string(count) + "\n";
  }

  family(out, "myriad_frame_seconds", "histogram",
         "Time to deliver one frame: render queue, GPU, readback and encoding.");
  histogram(out, "myriad_frame_seconds", frameBucketCounts_, frameCount_, frameSecondsSum_);
  family(out, "myriad_frame_queue_seconds", "histogram",
         "Time a frame waited before its work began: the render queue and other frames' GPU "
         "submissions ahead of it (a heavy frame's bounded parts included).");
  histogram(out, "myriad_frame_queue_seconds", queueBucketCounts_, queueCount_, queueSecondsSum_);

  single(out, "myriad_sessions", "gauge", "Sessions open now.",
         gauges.sessions);
  single(out, "myriad_streams", "gauge", "Frame streams open now.",
         gauges.streams);
  single(out, "myriad_stream_frames_shared_total", "counter",
         "Stream parts sent from a frame another stream of the session rendered (no render).",
         gauges.sharedStreamFrames);
  single(out, "myriad_video_encodes_total", "counter",
         "Frames encoded for video streams (one encode however many viewers share it).",
         gauges.videoEncodes);
  single(out, "myriad_video_encoders", "gauge",
         "Video encoders open now: one per session, target, size, codec, bitrate and fps streamed.",
         gauges.videoEncoders);
  single(out, "myriad_video_resyncs_total", "counter",
         "Video stream clients that fell behind and skipped to a key frame (each lowers the bitrate).",
         gauges.videoResyncs);
  single(out, "myriad_video_encoders_created_total", "counter",
         "Video encoders made (one per channel opened).", gauges.videoEncodersCreated);
  single(out, "myriad_video_encoders_freed_total", "counter",
         "Video encoders freed (their channel's last stream ended); made minus freed are alive.",
         gauges.videoEncodersFreed);
  single(out, "myriad_encode_threads", "gauge",
         "Threads of the video encoder pool every session's streams share (--encode-threads).",
         gauges.encodeThreads);
  single(out, "myriad_encode_queue_depth", "gauge",
         "Video encodes waiting for their session's turn on the encoder pool.", gauges.encodeQueued);
  single(out, "myriad_encode_running", "gauge", "Video encodes running on the encoder pool.",
         gauges.encodeRunning);
  family(out, "myriad_encode_seconds", "histogram",
         "Time one video frame's encode took on the encoder pool (its turn's wait not included).");
  histogram(out, "myriad_encode_seconds", gauges.encodeBucketCounts, gauges.encodeJobs,
            gauges.encodeSecondsSum, gauges.encodeBuckets);
  single(out, "myriad_encode_wait_seconds_total", "counter",
         "Time video encodes waited for their session's turn on the encoder pool, summed.",
         gauges.encodeWaitSecondsSum);
  single(out, "myriad_connections", "gauge", "HTTP connections open now (waiting or in a request).",
         gauges.connectionsOpen);
  single(out, "myriad_connections_accepted_total", "counter", "HTTP connections accepted.",
         gauges.connectionsAccepted);
  single(out, "myriad_connections_refused_total", "counter",
         "Connections answered 503 at --max-connections(-per-client) with none waiting to give way.",
         gauges.connectionsRefused);
  single(out, "myriad_connections_evicted_total", "counter",
         "Idle or half-sent connections closed at a connection cap for a newer one.",
         gauges.connectionsEvicted);
  single(out, "myriad_request_head_timeouts_total", "counter",
         "Request heads not sent whole within --header-timeout (408).",
         gauges.headTimeouts);
  single(out, "myriad_request_heads_refused_total", "counter",
         "Request heads refused before any route ran: malformed, or over a line or size bound.",
         gauges.headsRefused);
  single(out, "myriad_memory_reserved_bytes", "gauge",
         "Memory reserved now by requests in progress against --max-memory.",
         gauges.memoryReservedBytes);
  single(out, "myriad_memory_limit_bytes", "gauge", "--max-memory (0: none).",
         gauges.memoryLimitBytes);
  single(out, "myriad_gpu_memory_bytes", "gauge",
         "GPU memory held for scenes, lights and light lists.",
         gauges.gpuMemoryBytes);
  single(out, "myriad_validation_messages_total", "counter",
         "Vulkan validation messages since start-up (0 unless --validate).",
         gauges.validationMessages);
  if (extra_) out += extra_();
  return node_.empty() ? out : withLabel(out, "node", node_);
}

}  // namespace myriad::service
