// myriad-net-probe: a stream's latency as a remote client sees it (scripts/bench-network.py runs
// it in a network namespace behind a `tc netem` link). It creates a session on --url, opens one
// stream (JPEG parts, or VP9 / H.264 in Myriad's chunks) on a raw socket, decodes every picture
// the moment its last byte arrives (turbojpeg; encode::VideoDecoder: libvpx, OpenH264) and
// measures:
//   --mode edits: edit-to-decoded-frame. A still scene; every --interval ms the sun switches
//     between dark and bright (PATCH .../settings, timed from just before the request is sent);
//     the latency of an edit is from then to the first decoded picture whose mean brightness is
//     past the midpoint of the two states (calibrated first). Percentiles over --edits edits.
//   --mode cap: the stream of an animated scene for --seconds; at --at seconds it runs --run (a
//     command: the script changes the link's rate cap there). Per 0.5 s window after the change:
//     the bitrate the stream's pictures carry (by their server timestamps) and the lag (a
//     picture's decode time minus its server timestamp, less the least such difference seen
//     before the change: the delay beyond the link's own); adaptation time is when the carried
//     bitrate first fits the new cap (--cap-kbps), and the lag's growth is the last window's
//     median minus that of the window 2 s after the change.
//   --mode watch: the stream of an animated scene for --seconds, nothing edited: the pictures
//     delivered a second and the bitrate they carry after the first --warmup seconds (what one
//     of many sessions on a host gets: scripts/bench-sessions.py runs many probes at once).
// With --scene SEED the session's lights are --lights generated ones with that seed first (each
// probe of a run its own scene). Prints one JSON object on stdout.
//
// Usage: myriad-net-probe --url http://HOST:PORT --codec jpeg|vp9|h264 [--size WxH] [--fps F]
//        [--bitrate KBPS] [--mode edits|cap|watch] [--edits N] [--interval MS] [--seconds S]
//        [--at S --run CMD --cap-kbps K] [--lights N --scene SEED] [--warmup S]
#include <arpa/inet.h>
#include <httplib.h>
#include <netdb.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>
#include <turbojpeg.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "encode/video.h"
#include "protocol/constants.h"

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct Args {
  std::string host = "127.0.0.1";
  int port = 8080;
  std::string codec = "vp9";
  uint32_t width = 640, height = 360, fps = 30, bitrate = 0, lights = 64;
  std::string mode = "edits";
  int edits = 30;
  int intervalMs = 600;
  double seconds = 12.0;
  double at = -1.0;
  std::string run;
  double capKbps = 0.0;
  int scene = -1;  // the generated lights' seed; -1: the built-in scene's own lights
  double warmup = 2.0;
};

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "myriad-net-probe: %s\n", what.c_str());
  std::exit(1);
}

double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))];
}

// One decoded picture as the client had it.
struct Picture {
  Clock::time_point arrived;  // its last byte read
  Clock::time_point decoded;
  double mean = 0.0;          // mean of R, G and B over the picture
  size_t bytes = 0;           // its encoded size
  double serverUs = -1.0;     // video: its timestamp on the server's channel clock
};

double meanOf(const uint8_t* pixels, size_t count, size_t channels) {
  uint64_t sum = 0;
  for (size_t i = 0; i < count; ++i) {
    sum += pixels[i * channels] + pixels[i * channels + 1] + pixels[i * channels + 2];
  }
  return double(sum) / double(count * 3);
}

class StreamReader {
 public:
  StreamReader(const Args& a, const std::string& target) : args_(a) {
    addrinfo hints{};
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* found = nullptr;
    if (getaddrinfo(a.host.c_str(), std::to_string(a.port).c_str(), &hints, &found) != 0) {
      fail("cannot resolve " + a.host);
    }
    fd_ = socket(found->ai_family, SOCK_STREAM, 0);
    if (connect(fd_, found->ai_addr, found->ai_addrlen) != 0) fail("cannot connect");
    freeaddrinfo(found);
    const std::string request = "GET " + target + " HTTP/1.1\r\nHost: " + a.host + "\r\n\r\n";
    if (send(fd_, request.data(), request.size(), MSG_NOSIGNAL) < 0) fail("send failed");
    if (a.codec == "vp9") decoder_ = std::make_unique<myriad::encode::VideoDecoder>(
                              myriad::encode::VideoCodec::Vp9);
    if (a.codec == "h264") decoder_ = std::make_unique<myriad::encode::VideoDecoder>(
                               myriad::encode::VideoCodec::H264);
    jpeg_ = tjInitDecompress();
    thread_ = std::thread([this] { read(); });
  }
  ~StreamReader() {
    stop_ = true;
    shutdown(fd_, SHUT_RDWR);
    thread_.join();
    close(fd_);
    tjDestroy(jpeg_);
  }

  std::vector<Picture> pictures() const {
    std::lock_guard lock(mutex_);
    return pictures_;
  }
  uint64_t bytesRead() const { return bytes_.load(); }

 private:
  void read() {
    std::string raw, body;
    bool headDone = false;
    char buffer[65536];
    while (!stop_) {
      const ssize_t n = recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) return;
      bytes_ += uint64_t(n);
      raw.append(buffer, size_t(n));
      if (!headDone) {
        const size_t end = raw.find("\r\n\r\n");
        if (end == std::string::npos) continue;
        if (raw.compare(0, 12, "HTTP/1.1 200") != 0) fail("stream: " + raw.substr(0, end));
        raw.erase(0, end + 4);
        headDone = true;
      }
      for (;;) {  // HTTP chunks
        const size_t eol = raw.find("\r\n");
        if (eol == std::string::npos) break;
        const size_t size = std::strtoul(raw.c_str(), nullptr, 16);
        if (raw.size() < eol + 2 + size + 2) break;
        body.append(raw, eol + 2, size);
        raw.erase(0, eol + 2 + size + 2);
      }
      if (args_.codec == "h264") {
        mp4Boxes(body);
      } else if (decoder_) {
        videoChunks(body);
      } else {
        jpegParts(body);
      }
    }
  }

  void videoChunks(std::string& body) {
    while (body.size() >= 48) {
      uint32_t size = 0;
      uint64_t timestampUs = 0;
      std::memcpy(&size, body.data(), 4);
      const auto kind = uint8_t(body[4]);
      std::memcpy(&timestampUs, body.data() + 16, 8);
      if (body.size() < 48 + size) return;
      if (kind == 1 || kind == 2) {
        Picture p;
        p.arrived = Clock::now();
        p.bytes = size;
        p.serverUs = double(timestampUs);
        const auto* data = reinterpret_cast<const uint8_t*>(body.data() + 48);
        myriad::encode::VideoDecoder::Picture picture = decoder_->decode({data, size});
        p.decoded = Clock::now();
        p.mean = meanOf(picture.rgba.data(), size_t(picture.width) * picture.height, 4);
        std::lock_guard lock(mutex_);
        pictures_.push_back(p);
      }
      body.erase(0, 48 + size);
    }
  }

  static uint32_t be32(const char* p) {
    const auto* u = reinterpret_cast<const uint8_t*>(p);
    return uint32_t(u[0]) << 24 | uint32_t(u[1]) << 16 | uint32_t(u[2]) << 8 | u[3];
  }

  // Fragmented MP4 (codec=h264): SPS and PPS from the init segment's avcC, each mdat's
  // length-prefixed NAL units as Annex B for OpenH264.
  void mp4Boxes(std::string& body) {
    static const std::string kStart("\0\0\0\1", 4);
    while (body.size() >= 8) {
      const uint32_t size = be32(body.data());
      if (size < 8) fail("a bad MP4 box");
      if (body.size() < size) return;
      const std::string type = body.substr(4, 4);
      if (type == "moov") {
        const size_t avcC = body.find("avcC");
        if (avcC == std::string::npos || avcC > size) fail("no avcC in the init segment");
        const char* c = body.data() + avcC + 4;
        const auto u16 = [](const char* q) {
          return size_t(uint8_t(q[0])) << 8 | uint8_t(q[1]);
        };
        size_t at = 6;  // version, profile, compatibility, level, length size, SPS count
        const size_t spsLength = u16(c + at);
        parameterSets_ = kStart + std::string(c + at + 2, spsLength);
        at += 2 + spsLength + 1;  // and the PPS count
        const size_t ppsLength = u16(c + at);
        parameterSets_ += kStart + std::string(c + at + 2, ppsLength);
      } else if (type == "mdat") {
        Picture p;
        p.arrived = Clock::now();
        p.bytes = size - 8;
        std::string annexB = parameterSets_;
        for (size_t at = 8; at + 4 <= size;) {
          const uint32_t unit = be32(body.data() + at);
          annexB += kStart + body.substr(at + 4, unit);
          at += 4 + unit;
        }
        const auto* data = reinterpret_cast<const uint8_t*>(annexB.data());
        myriad::encode::VideoDecoder::Picture picture = decoder_->decode({data, annexB.size()});
        p.decoded = Clock::now();
        p.mean = meanOf(picture.rgba.data(), size_t(picture.width) * picture.height, 4);
        std::lock_guard lock(mutex_);
        pictures_.push_back(p);
      }
      body.erase(0, size);
    }
  }

  void jpegParts(std::string& body) {
    for (;;) {
      const size_t length = body.find("Content-Length: ");
      if (length == std::string::npos) return;
      const size_t headEnd = body.find("\r\n\r\n", length);
      if (headEnd == std::string::npos) return;
      const size_t size = std::strtoul(body.c_str() + length + 16, nullptr, 10);
      const bool jpeg = body.rfind("Content-Type: image/jpeg", length) != std::string::npos;
      if (body.size() < headEnd + 4 + size) return;
      if (jpeg) {
        Picture p;
        p.arrived = Clock::now();
        p.bytes = size;
        auto* data = reinterpret_cast<unsigned char*>(body.data() + headEnd + 4);
        int w = 0, h = 0, sub = 0, space = 0;
        if (tjDecompressHeader3(jpeg_, data, size, &w, &h, &sub, &space) == 0) {
          std::vector<uint8_t> rgb(size_t(w) * h * 3);
          tjDecompress2(jpeg_, data, size, rgb.data(), w, 0, h, TJPF_RGB, 0);
          p.decoded = Clock::now();
          p.mean = meanOf(rgb.data(), size_t(w) * h, 3);
          std::lock_guard lock(mutex_);
          pictures_.push_back(p);
        }
      }
      body.erase(0, headEnd + 4 + size);
    }
  }

  const Args& args_;
  int fd_ = -1;
  std::unique_ptr<myriad::encode::VideoDecoder> decoder_;
  tjhandle jpeg_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> bytes_{0};
  mutable std::mutex mutex_;
  std::vector<Picture> pictures_;
  std::string parameterSets_;  // H.264: SPS and PPS as Annex B
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) fail(flag + " needs a value");
    const std::string v = argv[++i];
    if (flag == "--url") {
      const size_t colon = v.rfind(':');
      if (v.rfind("http://", 0) != 0 || colon == std::string::npos) fail("--url http://HOST:PORT");
      a.host = v.substr(7, colon - 7);
      a.port = std::stoi(v.substr(colon + 1));
    } else if (flag == "--codec") {
      a.codec = v;
    } else if (flag == "--size") {
      if (std::sscanf(v.c_str(), "%ux%u", &a.width, &a.height) != 2) fail("--size WxH");
    } else if (flag == "--fps") {
      a.fps = uint32_t(std::stoul(v));
    } else if (flag == "--bitrate") {
      a.bitrate = uint32_t(std::stoul(v));
    } else if (flag == "--lights") {
      a.lights = uint32_t(std::stoul(v));
    } else if (flag == "--mode") {
      a.mode = v;
    } else if (flag == "--edits") {
      a.edits = std::stoi(v);
    } else if (flag == "--interval") {
      a.intervalMs = std::stoi(v);
    } else if (flag == "--seconds") {
      a.seconds = std::stod(v);
    } else if (flag == "--at") {
      a.at = std::stod(v);
    } else if (flag == "--run") {
      a.run = v;
    } else if (flag == "--cap-kbps") {
      a.capKbps = std::stod(v);
    } else if (flag == "--scene") {
      a.scene = std::stoi(v);
    } else if (flag == "--warmup") {
      a.warmup = std::stod(v);
    } else {
      fail("unknown flag " + flag);
    }
  }
  if (a.codec != "jpeg" && a.codec != "vp9" && a.codec != "h264") fail("--codec jpeg|vp9|h264");
  if (a.mode != "edits" && a.mode != "cap" && a.mode != "watch") fail("--mode edits|cap|watch");
  return a;
}

json latencies(const std::vector<double>& v) {
  return {{"n", v.size()},
          {"p50", percentile(v, 0.5)},
          {"p95", percentile(v, 0.95)},
          {"p99", percentile(v, 0.99)},
          {"max", v.empty() ? -1.0 : *std::max_element(v.begin(), v.end())},
          {"min", v.empty() ? -1.0 : *std::min_element(v.begin(), v.end())}};
}

// Edit-to-decoded-frame: edits every --interval ms, each timed to the first decoded picture
// past the brightness midpoint. --mode edits: --edits of them on a still scene; --mode cap: for
// --seconds on an animated scene, running --run at --at, and the carried bitrate, the picture
// rate and the edits' latency by half-second windows of arrival.
json measure(const Args& a, httplib::Client& http, const std::string& path,
             const httplib::Headers& auth, StreamReader& stream) {
  const auto sun = [&](double intensity) {
    const Clock::time_point sent = Clock::now();
    auto r = http.Patch(path + "/settings", auth,
                        R"({"sun": {"intensity": )" + std::to_string(intensity) + "}}",
                        "application/json");
    if (!r || r->status != 200) fail("PATCH settings failed");
    return sent;
  };
  const double dark = 0.0, bright = 6.0;
  // Calibrate: the two states' brightness.
  sun(dark);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const std::vector<Picture> darkSeen = stream.pictures();
  sun(bright);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const std::vector<Picture> seen = stream.pictures();
  if (darkSeen.empty() || seen.size() <= darkSeen.size()) fail("no picture came to calibrate");
  const double darkMean = darkSeen.back().mean, brightMean = seen.back().mean;
  const double mid = (darkMean + brightMean) / 2.0;
  if (brightMean - darkMean < 4.0) fail("the sun changes the picture too little to time edits");

  const bool timed = a.mode == "cap";
  const Clock::time_point start = Clock::now();
  Clock::time_point changedAt = start + std::chrono::hours(1);
  bool ran = a.at < 0;
  struct Edit {
    Clock::time_point sent;
    double ms = -1.0;  // -1: no picture showed it within 5 s
  };
  std::vector<Edit> edits;
  bool isBright = true;
  for (int i = 0;; ++i) {
    if (!timed && i >= a.edits) break;
    if (timed && Clock::now() - start >= std::chrono::duration<double>(a.seconds)) break;
    if (!ran && Clock::now() - start >= std::chrono::duration<double>(a.at)) {
      changedAt = Clock::now();
      if (!a.run.empty() && std::system(a.run.c_str()) != 0) fail("--run failed: " + a.run);
      ran = true;
    }
    isBright = !isBright;
    const Clock::time_point sent = sun(isBright ? bright : dark);
    Edit edit{sent};
    const Clock::time_point deadline = sent + std::chrono::seconds(5);
    size_t looked = 0;
    while (edit.ms < 0 && Clock::now() < deadline) {
      const std::vector<Picture> pictures = stream.pictures();
      for (; looked < pictures.size(); ++looked) {
        const Picture& p = pictures[looked];
        if (p.arrived >= sent && (isBright ? p.mean > mid : p.mean < mid)) {
          edit.ms = ms(p.decoded - sent);
          break;
        }
      }
      if (edit.ms < 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    edits.push_back(edit);
    std::this_thread::sleep_until(sent + std::chrono::milliseconds(a.intervalMs));
  }
  std::vector<double> all;
  int missed = 0;
  for (const Edit& e : edits) {
    if (e.ms >= 0) {
      all.push_back(e.ms);
    } else {
      ++missed;
    }
  }
  json out = {{"edits", edits.size()},
              {"missed", missed},
              {"darkMean", darkMean},
              {"brightMean", brightMean},
              {"editToDecodedMs", latencies(all)}};
  if (!timed) return out;

  // By half-second windows of arrival: carried kbps, pictures, the edits' latency.
  const std::vector<Picture> pictures = stream.pictures();
  const double changeS = std::chrono::duration<double>(changedAt - start).count();
  json windows = json::array();
  double adaptedAfter = -1.0;
  std::vector<double> before, early, late;  // edit latencies: before the change, 2-4 s after, the last 2 s
  for (const Edit& e : edits) {
    if (e.ms < 0) continue;
    const double t = std::chrono::duration<double>(e.sent - start).count();
    if (t < changeS) before.push_back(e.ms);
    if (t >= changeS + 2.0 && t < changeS + 4.0) early.push_back(e.ms);
    if (t >= a.seconds - 2.0) late.push_back(e.ms);
  }
  for (double w = 0.0; w + 0.5 <= a.seconds + 1e-9; w += 0.5) {
    double bytes = 0.0;
    int count = 0;
    for (const Picture& p : pictures) {
      const double t = std::chrono::duration<double>(p.arrived - start).count();
      if (t < w || t >= w + 0.5) continue;
      ++count;
      bytes += double(p.bytes);
    }
    std::vector<double> lags;
    for (const Edit& e : edits) {
      const double t = std::chrono::duration<double>(e.sent - start).count();
      if (e.ms >= 0 && t >= w && t < w + 0.5) lags.push_back(e.ms);
    }
    const double kbps = bytes * 8.0 / 1000.0 / 0.5;
    windows.push_back({{"t", w},
                       {"pictures", count},
                       {"kbps", std::round(kbps)},
                       {"editMs", lags.empty() ? -1.0 : percentile(lags, 0.5)}});
    if (adaptedAfter < 0 && w >= changeS && a.capKbps > 0 && count > 0 && kbps <= a.capKbps) {
      adaptedAfter = w + 0.5 - changeS;
    }
  }
  out["changeAtS"] = changeS;
  out["windows"] = windows;
  if (a.capKbps > 0) out["adaptedAfterS"] = adaptedAfter;
  out["editMsBeforeChange"] = latencies(before);
  out["editMsTwoToFourSecondsAfter"] = latencies(early);
  out["editMsLastTwoSeconds"] = latencies(late);
  return out;
}

// --mode watch: after --warmup s, for the rest of --seconds, the pictures delivered a second
// (between the first and the last arrival), the bitrate they carry and the gaps between them.
json watch(const Args& a, StreamReader& stream) {
  const Clock::time_point start = Clock::now();
  std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double>(a.seconds)));
  const Clock::time_point from = start + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(a.warmup));
  std::vector<Picture> counted;
  for (const Picture& p : stream.pictures()) {
    if (p.arrived >= from) counted.push_back(p);
  }
  json out = {{"pictures", counted.size()}, {"seconds", a.seconds - a.warmup}};
  if (counted.size() < 2) {
    out["deliveredFps"] = 0.0;
    return out;
  }
  const double span = std::chrono::duration<double>(counted.back().arrived -
                                                    counted.front().arrived).count();
  double bytes = 0.0;
  std::vector<double> gaps;
  for (size_t i = 0; i < counted.size(); ++i) {
    if (i > 0) {
      bytes += double(counted[i].bytes);
      gaps.push_back(ms(counted[i].arrived - counted[i - 1].arrived));
    }
  }
  out["deliveredFps"] = double(counted.size() - 1) / span;
  out["kbps"] = bytes * 8.0 / 1000.0 / span;
  out["gapMs"] = latencies(gaps);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  httplib::Client http(a.host, a.port);
  http.set_read_timeout(10, 0);
  auto created =
      http.Post(std::string(myriad::protocol::routes::kSessions), "{}", "application/json");
  if (!created || created->status != 201) fail("POST /v1/sessions failed");
  const json session = json::parse(created->body);
  const std::string path =
      std::string(myriad::protocol::routes::kSessions) + "/" + session["id"].get<std::string>();
  const std::string token = session["token"].get<std::string>();
  const httplib::Headers auth = {{"Authorization", "Bearer " + token}};
  const std::string settings =
      a.mode != "edits" ? R"({"animate": true, "markers": false})" : R"({"markers": false})";
  auto r = http.Patch(path + "/settings", auth, settings, "application/json");
  if (!r || r->status != 200) fail("PATCH settings failed");
  if (a.scene >= 0) {
    const json generate = {{"count", a.lights}, {"seed", a.scene}};
    r = http.Post(path + "/lights/generate", auth, generate.dump(), "application/json");
    if (!r || r->status / 100 != 2) fail("POST lights/generate failed");
  }
  std::string target = path + "/stream?width=" + std::to_string(a.width) +
                       "&height=" + std::to_string(a.height) + "&fps=" + std::to_string(a.fps) +
                       "&token=" + token;
  if (a.codec != "jpeg") target += "&codec=" + a.codec;
  if (a.codec != "jpeg" && a.bitrate > 0) target += "&bitrate=" + std::to_string(a.bitrate);
  json report = {{"codec", a.codec},
                 {"size", std::to_string(a.width) + "x" + std::to_string(a.height)},
                 {"fps", a.fps},
                 {"bitrateKbps", a.bitrate},
                 {"mode", a.mode}};
  {
    StreamReader stream(a, target);
    report.update(a.mode == "watch" ? watch(a, stream) : measure(a, http, path, auth, stream));
    report["bytesRead"] = stream.bytesRead();
  }
  http.Delete(path, auth);
  std::printf("%s\n", report.dump().c_str());
  return 0;
}
