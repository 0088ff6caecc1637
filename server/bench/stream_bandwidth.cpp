// myriad-stream-bandwidth: what the live view costs on the wire, through a running myriad-server's
// HTTP API as a client sees it. One session with N generated lights, animated (the lights move
// every frame), streamed for a while as JPEG (multipart) and as video (VP8/VP9): Mbit/s, bytes
// per frame, delivered fps, encode ms per frame; for video also the quality of the decoded frames
// (libvpx's decoder here) as PSNR against the PNG frame of the same state (GET .../frame?time=
// with the animation time the chunk header names), and the input-to-frame latency: from sending a
// camera PATCH to the arrival of the first chunk that shows it (its session version). Prints one
// JSON document. server/bench/stream_bandwidth.sh starts the server and runs this against it.
// With --viewers N (N > 1), N - 1 more streams of each video (a viewer token's, same query) run
// through the bandwidth measurement, as pages watching the session would: the report adds renders
// and encodes per second (GET .../stats "frames", /metrics myriad_video_encodes_total), the
// encoders open, and each viewer's delivered fps (the server shares one render and one encoder).
#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/png.h"
#include "encode/video.h"
#include "protocol/constants.h"

using nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace encode = myriad::encode;
namespace protocol = myriad::protocol;

namespace {

struct Options {
  std::string host = "127.0.0.1";
  int port = 0;
  uint32_t width = 1280;
  uint32_t height = 720;
  uint32_t fps = 30;
  uint32_t lights = 1000;
  double seconds = 10.0;
  int jpegQuality = 85;
  std::vector<std::string> codecs = {"vp8", "vp9"};
  uint32_t bitrateKbps = 0;  // 0: the server's default
  uint32_t psnrSamples = 8;
  uint32_t latencyEdits = 10;
  uint32_t viewers = 1;
  std::string jsonPath;
};

[[noreturn]] void usage(const std::string& problem) {
  std::fprintf(stderr,
               "myriad-stream-bandwidth: %s\n"
               "usage: myriad-stream-bandwidth --url http://HOST:PORT [--width 1280] [--height 720]\n"
               "         [--fps 30] [--lights 1000] [--seconds 10] [--jpeg-quality 85]\n"
               "         [--codecs vp8,vp9] [--bitrate KBPS (default: the server's)]\n"
               "         [--psnr-samples 8] [--latency-edits 10] [--viewers 1] [--json FILE]\n",
               problem.c_str());
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  auto number = [&](int& i, const char* name) {
    if (i + 1 >= argc) usage(std::string(name) + " needs a value");
    try {
      return std::stod(argv[++i]);
    } catch (const std::exception&) {
      usage(std::string(name) + " needs a number, got " + argv[i]);
    }
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--url") {
      if (i + 1 >= argc) usage("--url needs a value");
      std::string url = argv[++i];
      const std::string prefix = "http://";
      if (url.rfind(prefix, 0) != 0) usage("--url must start with http://");
      url = url.substr(prefix.size());
      while (!url.empty() && url.back() == '/') url.pop_back();
      const size_t colon = url.rfind(':');
      if (colon == std::string::npos) usage("--url needs a port");
      o.host = url.substr(0, colon);
      o.port = std::stoi(url.substr(colon + 1));
    } else if (a == "--width") {
      o.width = uint32_t(number(i, "--width"));
    } else if (a == "--height") {
      o.height = uint32_t(number(i, "--height"));
    } else if (a == "--fps") {
      o.fps = uint32_t(number(i, "--fps"));
    } else if (a == "--lights") {
      o.lights = uint32_t(number(i, "--lights"));
    } else if (a == "--seconds") {
      o.seconds = number(i, "--seconds");
    } else if (a == "--jpeg-quality") {
      o.jpegQuality = int(number(i, "--jpeg-quality"));
    } else if (a == "--bitrate") {
      o.bitrateKbps = uint32_t(number(i, "--bitrate"));
    } else if (a == "--psnr-samples") {
      o.psnrSamples = uint32_t(number(i, "--psnr-samples"));
    } else if (a == "--viewers") {
      o.viewers = uint32_t(number(i, "--viewers"));
      if (o.viewers < 1 || o.viewers > 32) usage("--viewers must be 1 to 32");
    } else if (a == "--latency-edits") {
      o.latencyEdits = uint32_t(number(i, "--latency-edits"));
    } else if (a == "--codecs") {
      if (i + 1 >= argc) usage("--codecs needs a value");
      o.codecs.clear();
      std::string list = argv[++i];
      size_t at = 0;
      while (at <= list.size()) {
        size_t comma = list.find(',', at);
        if (comma == std::string::npos) comma = list.size();
        std::string name = list.substr(at, comma - at);
        if (!name.empty()) o.codecs.push_back(name);
        at = comma + 1;
      }
    } else if (a == "--json") {
      if (i + 1 >= argc) usage("--json needs a value");
      o.jsonPath = argv[++i];
    } else {
      usage("unknown option " + a);
    }
  }
  if (o.port == 0) usage("--url is required");
  return o;
}

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Api {
 public:
  Api(const Options& o) : client_(o.host, o.port) {
    client_.set_read_timeout(600, 0);
    client_.set_connection_timeout(10, 0);
  }
  json call(const std::string& method, const std::string& path, const json& body = nullptr) {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    httplib::Result res =
        method == "GET"    ? client_.Get(path, headers)
        : method == "POST" ? client_.Post(path, headers, body.dump(), "application/json")
                           : client_.Patch(path, headers, body.dump(), "application/json");
    if (!res) throw Fail(method + " " + path + ": " + httplib::to_string(res.error()));
    if (res->status >= 300) {
      throw Fail(method + " " + path + ": " + std::to_string(res->status) + " " + res->body);
    }
    return res->body.empty() ? json(nullptr) : json::parse(res->body);
  }
  std::string getBytes(const std::string& path) {
    httplib::Result res = client_.Get(path, {{"Authorization", "Bearer " + token}});
    if (!res || res->status != 200) throw Fail("GET " + path + " failed");
    return res->body;
  }
  std::string token;

 private:
  httplib::Client client_;
};

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
}
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t index = std::min(v.size() - 1, size_t(std::ceil(p * double(v.size()))) - (p > 0 ? 1 : 0));
  return v[index];
}
double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

// Reads one stream on its own thread, handing every received piece to `onBytes` (under the
// reader's mutex) until stop() or the stream ends.
class StreamRun {
 public:
  using OnBytes = std::function<void(const char*, size_t)>;
  StreamRun(const Options& o, std::string path, std::string token, OnBytes onBytes)
      : client_(o.host, o.port), onBytes_(std::move(onBytes)) {
    client_.set_read_timeout(600, 0);
    thread_ = std::thread([this, path = std::move(path), token = std::move(token)] {
      httplib::Result res = client_.Get(
          path, {{"Authorization", "Bearer " + token}},
          [this](const httplib::Response& r) {
            status_ = r.status;
            return r.status == 200;
          },
          [this](const char* data, size_t size) {
            {
              std::lock_guard lock(mutex);
              if (first_ == Clock::time_point{}) first_ = Clock::now();
              onBytes_(data, size);
            }
            return !stop_.load();
          });
      (void)res;
      done_ = true;
    });
  }
  ~StreamRun() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) {
      client_.stop();
      thread_.join();
    }
  }
  int status() const { return status_; }
  bool done() const { return done_; }
  std::mutex mutex;

 private:
  httplib::Client client_;
  OnBytes onBytes_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> done_{false};
  std::atomic<int> status_{0};
  Clock::time_point first_{};
};

std::string sizeQuery(const Options& o) {
  return "fps=" + std::to_string(o.fps) + "&width=" + std::to_string(o.width) +
         "&height=" + std::to_string(o.height);
}

// The multipart JPEG stream: parts counted by their Content-Length.
json measureJpeg(const Options& o, Api& api, const std::string& base) {
  size_t bytes = 0, parts = 0, jpegBytes = 0;
  std::string buffer;
  Clock::time_point firstPart{}, lastPart{};
  std::vector<double> encodeMs;
  StreamRun run(o, base + "/stream?format=jpeg&quality=" + std::to_string(o.jpegQuality) + "&" +
                       sizeQuery(o),
                api.token, [&](const char* data, size_t size) {
                  bytes += size;
                  buffer.append(data, size);
                  for (;;) {
                    const size_t header = buffer.find("\r\n\r\n");
                    if (header == std::string::npos) return;
                    const size_t lengthAt = buffer.find("Content-Length: ");
                    if (lengthAt == std::string::npos || lengthAt > header) return;
                    const size_t length = std::stoul(buffer.substr(lengthAt + 16));
                    if (buffer.size() < header + 4 + length) return;
                    ++parts;
                    jpegBytes += length;
                    lastPart = Clock::now();
                    if (parts == 1) firstPart = lastPart;
                    buffer.erase(0, header + 4 + length);
                  }
                });
  // The last frame's encode time, sampled from GET .../stats while the stream runs.
  const auto end = Clock::now() + std::chrono::duration<double>(o.seconds);
  while (Clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    json stats = api.call("GET", base + "/stats");
    if (!stats["frame"].is_null()) encodeMs.push_back(stats["frame"]["encodeMs"].get<double>());
  }
  run.stop();
  if (run.status() != 200) throw Fail("the JPEG stream answered " + std::to_string(run.status()));
  if (parts < 2) throw Fail("the JPEG stream delivered fewer than 2 frames");
  const double span = std::chrono::duration<double>(lastPart - firstPart).count();
  const double fps = double(parts - 1) / span;
  const double bytesPerFrame = double(jpegBytes) / double(parts);
  return {{"quality", o.jpegQuality},
          {"frames", parts},
          {"deliveredFps", round3(fps)},
          {"bytesPerFrame", std::llround(bytesPerFrame)},
          {"mbitPerSecondDelivered", round3(bytesPerFrame * 8.0 * fps / 1e6)},
          {"mbitPerSecondAtFps", round3(bytesPerFrame * 8.0 * o.fps / 1e6)},
          {"encodeMsMean", round3(mean(encodeMs))},
          {"encodeMsP95", round3(percentile(encodeMs, 0.95))}};
}

// A counter of /metrics by its name (0 when absent).
uint64_t metric(Api& api, const std::string& name) {
  const std::string text = api.getBytes(std::string(protocol::routes::kMetrics));
  const size_t at = text.find("\n" + name + " ");
  return at == std::string::npos ? 0 : std::stoull(text.substr(at + name.size() + 2));
}

struct Chunk {
  uint8_t kind = 0;
  uint32_t sequence = 0;
  uint64_t version = 0;
  double time = 0.0;
  uint32_t encodeUs = 0;
  size_t payloadBytes = 0;
  Clock::time_point arrived;
};

json measureVideo(const Options& o, Api& api, const std::string& base, const std::string& codecName) {
  encode::VideoCodec codec = encode::VideoCodec::Vp8;
  bool known = false;
  for (size_t i = 0; i < protocol::kVideoCodecs.size(); ++i) {
    if (protocol::kVideoCodecs[i] == codecName) {
      codec = static_cast<encode::VideoCodec>(i);
      known = true;
    }
  }
  if (!known) throw Fail("unknown codec " + codecName);
  if (codec == encode::VideoCodec::H264) {
    // Its stream is fragmented MP4 (container=mp4), not the chunks this bench reads.
    throw Fail("h264 streams come only as fragmented MP4; this bench reads Myriad's chunks "
               "(vp8, vp9)");
  }
  encode::VideoDecoder decoder(codec);
  std::vector<Chunk> chunks;
  std::vector<double> decodeMs;
  struct Sample {
    double time;
    std::vector<uint8_t> rgba;
  };
  std::vector<Sample> samples;
  size_t bytes = 0;
  std::string buffer;
  std::string decodeError;
  std::condition_variable arrivedCv;
  bool sampling = true;
  // Spread the PSNR samples over the measured seconds: the first frame after each due time.
  const Clock::time_point started = Clock::now();
  const double sampleEvery = o.seconds / std::max<uint32_t>(1, o.psnrSamples);
  std::string query = "/stream?codec=" + codecName + "&" + sizeQuery(o);
  if (o.bitrateKbps) query += "&bitrate=" + std::to_string(o.bitrateKbps);
  StreamRun run(o, base + query, api.token, [&](const char* data, size_t size) {
    bytes += size;
    buffer.append(data, size);
    while (buffer.size() >= protocol::video_chunk::kHeaderBytes) {
      uint32_t payload = 0;
      std::memcpy(&payload, buffer.data(), 4);
      if (buffer.size() < protocol::video_chunk::kHeaderBytes + payload) break;
      Chunk c;
      c.kind = uint8_t(buffer[4]);
      std::memcpy(&c.sequence, buffer.data() + 12, 4);
      std::memcpy(&c.version, buffer.data() + 24, 8);
      std::memcpy(&c.time, buffer.data() + 32, 8);
      std::memcpy(&c.encodeUs, buffer.data() + 40, 4);
      c.payloadBytes = payload;
      c.arrived = Clock::now();
      if (c.kind != protocol::video_chunk::kKeepAlive && decodeError.empty()) {
        const auto start = Clock::now();
        try {
          encode::VideoDecoder::Picture picture = decoder.decode(
              {reinterpret_cast<const uint8_t*>(buffer.data()) + protocol::video_chunk::kHeaderBytes,
               payload});
          decodeMs.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
          const double due = sampleEvery * (double(samples.size()) + 0.5);
          if (sampling && samples.size() < o.psnrSamples &&
              std::chrono::duration<double>(c.arrived - started).count() >= due) {
            samples.push_back({c.time, std::move(picture.rgba)});
          }
        } catch (const std::exception& e) {
          decodeError = e.what();
        }
      }
      if (c.kind != protocol::video_chunk::kKeepAlive) chunks.push_back(c);
      buffer.erase(0, protocol::video_chunk::kHeaderBytes + payload);
    }
    arrivedCv.notify_all();
  });

  // More pages watching (--viewers): each counts the chunks with a picture it gets.
  struct Viewer {
    std::unique_ptr<StreamRun> run;
    std::string buffer;
    size_t pictures = 0;
  };
  std::vector<std::unique_ptr<Viewer>> viewers;
  if (o.viewers > 1) {
    const std::string viewerToken =
        api.call("POST", base + "/tokens", {{"role", "viewer"}})["token"].get<std::string>();
    for (uint32_t v = 1; v < o.viewers; ++v) {
      auto viewer = std::make_unique<Viewer>();
      Viewer* self = viewer.get();
      viewer->run = std::make_unique<StreamRun>(o, base + query, viewerToken, [self](const char* data, size_t size) {
        self->buffer.append(data, size);
        while (self->buffer.size() >= protocol::video_chunk::kHeaderBytes) {
          uint32_t payload = 0;
          std::memcpy(&payload, self->buffer.data(), 4);
          if (self->buffer.size() < protocol::video_chunk::kHeaderBytes + payload) break;
          if (uint8_t(self->buffer[4]) != protocol::video_chunk::kKeepAlive) ++self->pictures;
          self->buffer.erase(0, protocol::video_chunk::kHeaderBytes + payload);
        }
      });
      viewers.push_back(std::move(viewer));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // every viewer joined
  }
  const uint64_t rendersBefore = api.call("GET", base + "/stats")["frames"].get<uint64_t>();
  const uint64_t encodesBefore = metric(api, "myriad_video_encodes_total");
  std::vector<size_t> viewerPicturesBefore;
  for (auto& v : viewers) {
    std::lock_guard lock(v->run->mutex);
    viewerPicturesBefore.push_back(v->pictures);
  }

  // Bandwidth: the stream (and its viewers) for `seconds`.
  const Clock::time_point measureStart = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  json shared = nullptr;
  if (!viewers.empty()) {
    const double took = std::chrono::duration<double>(Clock::now() - measureStart).count();
    const uint64_t renders = api.call("GET", base + "/stats")["frames"].get<uint64_t>() - rendersBefore;
    const uint64_t encodes = metric(api, "myriad_video_encodes_total") - encodesBefore;
    json viewerFps = json::array();
    for (size_t v = 0; v < viewers.size(); ++v) {
      std::lock_guard lock(viewers[v]->run->mutex);
      viewerFps.push_back(round3(double(viewers[v]->pictures - viewerPicturesBefore[v]) / took));
    }
    shared = {{"viewers", o.viewers},
              {"rendersPerSecond", round3(double(renders) / took)},
              {"encodesPerSecond", round3(double(encodes) / took)},
              {"encodersOpen", metric(api, "myriad_video_encoders")},
              {"otherViewersFps", viewerFps}};
    for (auto& v : viewers) v->run->stop();
    viewers.clear();
  }
  std::vector<Chunk> measured;
  size_t measuredBytes = 0;
  {
    std::lock_guard lock(run.mutex);
    measured = chunks;
    measuredBytes = bytes;
    sampling = false;
  }
  if (run.status() != 200) throw Fail(codecName + " stream answered " + std::to_string(run.status()));
  if (measured.size() < 2) throw Fail(codecName + " stream delivered fewer than 2 frames");

  // Quality: each sampled decoded frame against the PNG frame of its animation time.
  std::vector<double> psnr;
  std::vector<Sample> taken;
  {
    std::lock_guard lock(run.mutex);
    taken = std::move(samples);
  }
  for (const Sample& sample : taken) {
    char time[64];
    std::snprintf(time, sizeof time, "%.17g", sample.time);
    // Before the latency edits move the camera: the PNG must show the camera of the sample.
    std::string png = api.getBytes(base + "/frame?format=png&width=" + std::to_string(o.width) +
                                   "&height=" + std::to_string(o.height) + "&time=" + time);
    psnr.push_back(encode::psnrRgb(
        sample.rgba,
        encode::decodePng({reinterpret_cast<const uint8_t*>(png.data()), png.size()}).rgba));
  }

  // Latency: camera edits, one at a time; each waits for the first chunk of a newer version.
  std::vector<double> latencyMs;
  for (uint32_t edit = 0; edit < o.latencyEdits; ++edit) {
    uint64_t versionBefore = 0;
    size_t seen = 0;
    {
      std::lock_guard lock(run.mutex);
      if (!chunks.empty()) versionBefore = chunks.back().version;
      seen = chunks.size();
    }
    const auto sent = Clock::now();
    api.call("PATCH", base + "/camera", {{"fovY", edit % 2 ? 50.0 : 55.0}});
    std::unique_lock lock(run.mutex);
    std::optional<double> latency;
    arrivedCv.wait_for(lock, std::chrono::seconds(60), [&] {
      for (size_t i = seen; i < chunks.size(); ++i) {
        if (chunks[i].version > versionBefore) {
          latency = std::chrono::duration<double, std::milli>(chunks[i].arrived - sent).count();
          return true;
        }
      }
      seen = chunks.size();
      return run.done();
    });
    lock.unlock();
    if (!latency) throw Fail(codecName + ": no frame showed camera edit " + std::to_string(edit));
    latencyMs.push_back(*latency);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  run.stop();
  if (!decodeError.empty()) throw Fail(codecName + ": " + decodeError);

  size_t payloadBytes = 0, keyFrames = 0;
  std::vector<double> encodeMs;
  for (const Chunk& c : measured) {
    payloadBytes += c.payloadBytes;
    keyFrames += c.kind == protocol::video_chunk::kKey;
    encodeMs.push_back(c.encodeUs / 1000.0);
  }
  const double span =
      std::chrono::duration<double>(measured.back().arrived - measured.front().arrived).count();
  const double fps = double(measured.size() - 1) / span;
  const double bytesPerFrame = double(payloadBytes) / double(measured.size());
  (void)measuredBytes;
  json out = {{"codec", codecName},
              {"frames", measured.size()},
              {"keyFrames", keyFrames},
              {"deliveredFps", round3(fps)},
              {"bytesPerFrame", std::llround(bytesPerFrame)},
              {"mbitPerSecondDelivered", round3(bytesPerFrame * 8.0 * fps / 1e6)},
              {"encodeMsMean", round3(mean(encodeMs))},
              {"encodeMsP95", round3(percentile(encodeMs, 0.95))},
              {"decodeMsMean", round3(mean(decodeMs))},
              {"psnrDbMean", round3(mean(psnr))},
              {"psnrDbMin", psnr.empty() ? 0.0 : round3(*std::min_element(psnr.begin(), psnr.end()))},
              {"psnrSamples", psnr.size()},
              {"latencyMsMedian", round3(percentile(latencyMs, 0.5))},
              {"latencyMsMax", latencyMs.empty() ? 0.0 : round3(*std::max_element(latencyMs.begin(), latencyMs.end()))},
              {"latencyEdits", latencyMs.size()}};
  if (o.bitrateKbps) out["bitrateKbps"] = o.bitrateKbps;
  if (!shared.is_null()) out["shared"] = shared;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  try {
    Api api(o);
    json info = api.call("GET", std::string(protocol::routes::kInfo));
    json created = api.call("POST", std::string(protocol::routes::kSessions), json::object());
    api.token = created["token"].get<std::string>();
    const std::string base =
        protocol::expandRoute(protocol::routes::kSession, "id", created["id"].get<std::string>());
    api.call("POST", base + "/lights/generate", {{"count", o.lights}, {"seed", 7}});
    api.call("PATCH", base + "/settings", {{"animate", true}});
    // One frame first: pipelines and buffers at this size exist before anything is timed.
    api.getBytes(base + "/frame?format=png&width=" + std::to_string(o.width) + "&height=" +
                 std::to_string(o.height));

    json report;
    char date[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    report["date"] = date;
    report["device"] = info["device"]["name"];
    report["deviceIsCpu"] = info["device"]["isCpu"];
    report["hardwareThreads"] = std::thread::hardware_concurrency();
    report["width"] = o.width;
    report["height"] = o.height;
    report["fps"] = o.fps;
    report["lights"] = o.lights;
    report["animated"] = true;
    report["secondsPerStream"] = o.seconds;
    report["jpeg"] = measureJpeg(o, api, base);
    report["video"] = json::array();
    const json camera = api.call("GET", base + "/camera");
    for (const std::string& codec : o.codecs) {
      report["video"].push_back(measureVideo(o, api, base, codec));
      // The latency edits moved the camera: every stream starts from the same view.
      api.call("PATCH", base + "/camera", {{"fovY", camera["fovY"]}});
    }
    api.call("PATCH", base + "/settings", {{"animate", false}});
    const std::string text = report.dump(2);
    std::cout << text << "\n";
    if (!o.jsonPath.empty()) std::ofstream(o.jsonPath) << text << "\n";
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-stream-bandwidth: %s\n", e.what());
    return 1;
  }
  return 0;
}
