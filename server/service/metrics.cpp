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

}  // namespace

void Metrics::countRequest(std::string_view routeTemplate, int status) {
  std::lock_guard lock(mutex_);
  ++requests_[{std::string(routeTemplate), status}];
}

void Metrics::observeFrame(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) seconds = 0.0;
  std::lock_guard lock(mutex_);
  for (size_t i = 0; i < kFrameBuckets.size(); ++i) {
    if (seconds <= kFrameBuckets[i]) {
      ++frameBucketCounts_[i];
      break;
    }
  }
  ++frameCount_;
  frameSecondsSum_ += seconds;
}

uint64_t Metrics::requests(std::string_view routeTemplate, int status) const {
  std::lock_guard lock(mutex_);
  auto it = requests_.find({std::string(routeTemplate), status});
  return it == requests_.end() ? 0 : it->second;
}

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
  uint64_t cumulative = 0;
  for (size_t i = 0; i < kFrameBuckets.size(); ++i) {
    cumulative += frameBucketCounts_[i];
    out += "myriad_frame_seconds_bucket{le=\"" + number(kFrameBuckets[i]) + "\"} " +
           std::to_string(cumulative) + "\n";
  }
  out += "myriad_frame_seconds_bucket{le=\"+Inf\"} " + std::to_string(frameCount_) + "\n";
  out += "myriad_frame_seconds_sum " + number(frameSecondsSum_) + "\n";
  out += "myriad_frame_seconds_count " + std::to_string(frameCount_) + "\n";

  family(out, "myriad_sessions", "gauge", "Sessions open now.");
  out += "myriad_sessions " + std::to_string(gauges.sessions) + "\n";
  family(out, "myriad_streams", "gauge", "Frame streams open now.");
  out += "myriad_streams " + std::to_string(gauges.streams) + "\n";
  family(out, "myriad_stream_frames_shared_total", "counter",
         "Stream parts sent from a frame another stream of the session rendered (no render).");
  out += "myriad_stream_frames_shared_total " + std::to_string(gauges.sharedStreamFrames) + "\n";
  family(out, "myriad_video_encodes_total", "counter",
         "Frames encoded for video streams (one encode however many viewers share it).");
  out += "myriad_video_encodes_total " + std::to_string(gauges.videoEncodes) + "\n";
  family(out, "myriad_video_encoders", "gauge",
         "Video encoders open now: one per session, target, size, codec, bitrate and fps streamed.");
  out += "myriad_video_encoders " + std::to_string(gauges.videoEncoders) + "\n";
  family(out, "myriad_video_resyncs_total", "counter",
         "Video stream clients that fell behind and skipped to a key frame (each lowers the bitrate).");
  out += "myriad_video_resyncs_total " + std::to_string(gauges.videoResyncs) + "\n";
  family(out, "myriad_gpu_memory_bytes", "gauge",
         "GPU memory held for scenes, lights and light lists.");
  out += "myriad_gpu_memory_bytes " + std::to_string(gauges.gpuMemoryBytes) + "\n";
  family(out, "myriad_validation_messages_total", "counter",
         "Vulkan validation messages since start-up (0 unless --validate).");
  out += "myriad_validation_messages_total " + std::to_string(gauges.validationMessages) + "\n";
  return out;
}

}  // namespace myriad::service
