// myriad-video-settings-bench: the video encoders' settings (speed, key frame interval, rate
// control buffer, threads) measured on this machine, for choosing the defaults in
// encode/video.cpp (docs/ARCHITECTURE.md, "Encoder settings"). CPU only: no Vulkan, no server.
//
// Each configuration encodes the same animated picture (a rendered-looking scene: gradients, a
// textured floor, moving lights) for --frames frames at --fps, decodes every packet and reports
// per configuration: encode ms (median, p95), the bitrate made against the target, PSNR (mean,
// min), the key frame's and the largest delta's bytes, and the delay a frame would meet on a link
// of exactly the target bitrate (its bytes after the bytes still queued from the frames before:
// median, p95, max), which is what a rate control's burstiness costs in latency.
//
// Usage: myriad-video-settings-bench [--size WxH] [--frames N] [--fps F] [--kbps K]
//        [--codec vp8|vp9|h264|all] [--threads T]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "encode/video.h"

using namespace myriad::encode;

namespace {

struct Args {
  uint32_t width = 320, height = 180, frames = 150, fps = 30, kbps = 1000, threads = 1;
  std::string codec = "all";
};

// A rendered-looking frame at time t: a sky gradient, a checkered floor in perspective and four
// lights moving over it, each a soft pool of light.
void drawScene(std::vector<uint8_t>& rgba, uint32_t w, uint32_t h, double t) {
  const uint32_t horizon = h * 2 / 5;
  double lx[4], ly[4];
  for (int i = 0; i < 4; ++i) {
    lx[i] = 0.5 + 0.35 * std::sin(t * (0.7 + 0.3 * i) + i * 1.7);
    ly[i] = 0.6 + 0.3 * std::cos(t * (0.5 + 0.2 * i) + i);
  }
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = &rgba[(size_t(y) * w + x) * 4];
      double r, g, b;
      if (y < horizon) {
        const double s = double(y) / horizon;
        r = 40 + 60 * s;
        g = 60 + 70 * s;
        b = 120 + 60 * s;
      } else {
        const double depth = double(h - horizon) / double(y - horizon + 1);
        const double u = (double(x) / w - 0.5) * depth * 4.0;
        const double v = depth * 2.0 + t * 0.3;
        const bool check = (int(std::floor(u)) + int(std::floor(v))) & 1;
        double base = check ? 90 : 50;
        const double fx = double(x) / w, fy = double(y) / h;
        double light = 0.2;
        for (int i = 0; i < 4; ++i) {
          const double dx = fx - lx[i], dy = (fy - ly[i]) * 1.8;
          light += 1.6 * std::exp(-(dx * dx + dy * dy) * 40.0);
        }
        r = base * light * 1.1;
        g = base * light;
        b = base * light * 0.8;
      }
      p[0] = uint8_t(std::clamp(r, 0.0, 255.0));
      p[1] = uint8_t(std::clamp(g, 0.0, 255.0));
      p[2] = uint8_t(std::clamp(b, 0.0, 255.0));
      p[3] = 255;
    }
  }
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5));
  return v[i];
}

struct Config {
  VideoCodec codec;
  int speed;
  uint32_t keyInterval;  // frames; 0: default
  uint32_t bufferMs;     // 0: default
  std::string label;
};

void runOne(const Args& a, const Config& c, const std::vector<std::vector<uint8_t>>& frames) {
  VideoSettings s;
  s.codec = c.codec;
  s.width = a.width;
  s.height = a.height;
  s.fps = a.fps;
  s.bitrateKbps = a.kbps;
  s.threads = a.threads;
  s.speed = c.speed;
  s.keyInterval = c.keyInterval;
  s.bufferMs = c.bufferMs;
  VideoEncoder encoder(s);
  VideoDecoder decoder(c.codec);
  std::vector<double> ms, psnr, delay;
  uint64_t bytes = 0;
  size_t keyBytes = 0, maxDelta = 0, keys = 0;
  const double linkBytesPerMs = a.kbps * 1000.0 / 8.0 / 1000.0;
  double linkFreeAt = 0.0;  // ms
  for (size_t i = 0; i < frames.size(); ++i) {
    const uint64_t tsMs = i * 1000 / a.fps;
    const auto start = std::chrono::steady_clock::now();
    VideoPacket packet = encoder.encode(frames[i], tsMs, false);
    const double took =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ms.push_back(took);
    bytes += packet.data.size();
    if (packet.key) {
      ++keys;
      if (i == 0) keyBytes = packet.data.size();
    } else {
      maxDelta = std::max(maxDelta, packet.data.size());
    }
    // The link: the frame leaves when encoded and when the frames before it have gone.
    const double ready = double(tsMs) + took;
    const double startSend = std::max(ready, linkFreeAt);
    linkFreeAt = startSend + double(packet.data.size()) / linkBytesPerMs;
    if (i >= a.fps) delay.push_back(linkFreeAt - double(tsMs));  // after the first second
    VideoDecoder::Picture picture = decoder.decode(packet.data);
    psnr.push_back(psnrRgb(picture.rgba, frames[i]));
  }
  const double seconds = double(frames.size()) / a.fps;
  double psnrMean = 0.0;
  for (double p : psnr) psnrMean += p;
  psnrMean /= double(psnr.size());
  std::printf(
      "%-5s %-22s  encode ms p50 %6.2f p95 %6.2f | %5.0f kbps of %u | PSNR mean %5.2f min %5.2f | "
      "key %6zu B, max delta %6zu B, keys %zu | link delay ms p50 %6.1f p95 %6.1f max %6.1f\n",
      std::string(videoCodecName(c.codec)).c_str(), c.label.c_str(), percentile(ms, 0.5),
      percentile(ms, 0.95), double(bytes) * 8.0 / 1000.0 / seconds, a.kbps, psnrMean,
      *std::min_element(psnr.begin(), psnr.end()), keyBytes, maxDelta, keys,
      percentile(delay, 0.5), percentile(delay, 0.95),
      delay.empty() ? 0.0 : *std::max_element(delay.begin(), delay.end()));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--size") {
      if (std::sscanf(value.c_str(), "%ux%u", &a.width, &a.height) != 2) return 2;
    } else if (key == "--frames") {
      a.frames = uint32_t(std::stoul(value));
    } else if (key == "--fps") {
      a.fps = uint32_t(std::stoul(value));
    } else if (key == "--kbps") {
      a.kbps = uint32_t(std::stoul(value));
    } else if (key == "--threads") {
      a.threads = uint32_t(std::stoul(value));
    } else if (key == "--codec") {
      a.codec = value;
    } else {
      std::fprintf(stderr, "myriad-video-settings-bench: unknown option %s\n", key.c_str());
      return 2;
    }
  }
  std::vector<std::vector<uint8_t>> frames(a.frames);
  for (uint32_t i = 0; i < a.frames; ++i) {
    frames[i].resize(size_t(a.width) * a.height * 4);
    drawScene(frames[i], a.width, a.height, double(i) / a.fps);
  }
  std::printf("%ux%u, %u frames at %u fps, %u kbit/s, %u encoder thread(s)\n", a.width, a.height,
              a.frames, a.fps, a.kbps, a.threads);
  const int d = VideoSettings::kDefaultSpeed;
  std::vector<Config> configs;
  if (a.codec == "all" || a.codec == "vp9") {
    for (int speed : {6, 7, 8, 9}) {
      configs.push_back({VideoCodec::Vp9, speed, 0, 0, "speed " + std::to_string(speed)});
    }
    for (uint32_t buffer : {100u, 200u, 300u, 500u}) {
      configs.push_back({VideoCodec::Vp9, d, 0, buffer, "buffer " + std::to_string(buffer) + " ms"});
    }
    configs.push_back({VideoCodec::Vp9, d, a.fps * 2, 0, "key every 2 s"});
  }
  if (a.codec == "all" || a.codec == "vp8") {
    for (int speed : {6, 10, 14}) {
      configs.push_back({VideoCodec::Vp8, speed, 0, 0, "speed " + std::to_string(speed)});
    }
    for (uint32_t buffer : {100u, 200u, 300u}) {
      configs.push_back({VideoCodec::Vp8, d, 0, buffer, "buffer " + std::to_string(buffer) + " ms"});
    }
  }
  if (a.codec == "all" || a.codec == "h264") {
    for (int speed : {0, 1, 2}) {
      configs.push_back({VideoCodec::H264, speed, 0, 0, "complexity " + std::to_string(speed)});
    }
    configs.push_back({VideoCodec::H264, d, a.fps * 2, 0, "key every 2 s"});
  }
  for (const Config& c : configs) runOne(a, c, frames);
  return 0;
}
