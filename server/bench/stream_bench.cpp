// myriad-stream-bench: the frame pipeline as a client sees it, end to end through the real server
// (HTTP, render thread, encoder, multipart streams). It starts myriad-server (or uses --url),
// creates sessions with generated lights and animation on (so every stream part is a new frame),
// and reports, as one JSON object:
//   - request: one JPEG frame at --size, request to last byte on a kept-alive connection
//     (median and 90th percentile of --requests, after 3 warm-up requests);
//   - stream: one stream at --size (frames per second over --seconds, from the first part to the
//     last, so the first frame's latency is not counted);
//   - streams: --streams concurrent streams at --size, one session each: total and per-stream
//     fps, and the largest deviation of a stream from their mean, in percent;
//   - large: one stream at --large (skipped with --large none).
// Each stream measurement also carries its sessions' `pipeline` from GET .../stats (where the
// frames' time went: queue, record, GPU, GPU idle, fence wait, host copy, encode, send; medians
// over the session's last frames), read right after the streams end.
// Every stream asks fps=240 (the server's ceiling), so the pipeline, not the cap, sets the rate.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct Size {
  uint32_t width = 0;
  uint32_t height = 0;
  std::string text() const { return std::to_string(width) + "x" + std::to_string(height); }
};

struct Options {
  std::string server;  // myriad-server to start (default: next to this binary)
  std::string url;     // or a running server
  std::vector<std::string> serverArgs;
  uint32_t lights = 100000;
  double radiusMin = 0.5, radiusMax = 2.0;
  Size size{1920, 1080};
  std::optional<Size> large = Size{3840, 2160};
  uint32_t streams = 8;
  uint32_t requests = 20;
  double seconds = 10.0;
  int quality = 80;
  std::string json;
};

[[noreturn]] void usage(const std::string& problem) {
  if (!problem.empty()) std::fprintf(stderr, "myriad-stream-bench: %s\n", problem.c_str());
  std::fprintf(stderr,
      "usage: myriad-stream-bench [--server PATH | --url http://HOST:PORT] [--lights N]\n"
      "          [--radius MIN,MAX] [--size WxH] [--large WxH|none] [--streams N]\n"
      "          [--requests N] [--seconds S] [--quality Q] [--json PATH] [-- SERVER ARGS...]\n"
      "Starts myriad-server (default: the one next to this binary) on a free loopback port with\n"
      "SERVER ARGS (e.g. --device 0), or uses --url; every session gets N generated lights\n"
      "(default 100000, radii MIN..MAX, default 0.5,2), markers off, animation on. Reports one\n"
      "JPEG request at --size (default 1920x1080), one stream, --streams concurrent streams\n"
      "(default 8, one session each) and one stream at --large (default 3840x2160) as JSON on\n"
      "stdout (and in --json PATH). --seconds per stream measurement (default 10).\n");
  std::exit(problem.empty() ? 0 : 2);
}

Size parseSize(const std::string& text) {
  Size s;
  if (std::sscanf(text.c_str(), "%ux%u", &s.width, &s.height) != 2 || s.width == 0 ||
      s.height == 0) {
    usage("a size is WIDTHxHEIGHT, got \"" + text + "\"");
  }
  return s;
}

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") usage("");
    if (flag == "--") {
      for (++i; i < argc; ++i) o.serverArgs.push_back(argv[i]);
      break;
    }
    if (i + 1 >= argc) usage(flag + " needs a value");
    const std::string v = argv[++i];
    if (flag == "--server") {
      o.server = v;
    } else if (flag == "--url") {
      o.url = v;
    } else if (flag == "--lights") {
      o.lights = uint32_t(std::stoul(v));
    } else if (flag == "--radius") {
      if (std::sscanf(v.c_str(), "%lf,%lf", &o.radiusMin, &o.radiusMax) != 2) {
        usage("--radius is MIN,MAX");
      }
    } else if (flag == "--size") {
      o.size = parseSize(v);
    } else if (flag == "--large") {
      o.large = v == "none" ? std::nullopt : std::optional<Size>(parseSize(v));
    } else if (flag == "--streams") {
      o.streams = uint32_t(std::stoul(v));
    } else if (flag == "--requests") {
      o.requests = std::max(1u, uint32_t(std::stoul(v)));
    } else if (flag == "--seconds") {
      o.seconds = std::stod(v);
    } else if (flag == "--quality") {
      o.quality = std::stoi(v);
    } else if (flag == "--json") {
      o.json = v;
    } else {
      usage("unknown flag " + flag);
    }
  }
  return o;
}

// The server this run started: stopped (SIGTERM, then waited for) when destroyed.
class StartedServer {
 public:
  StartedServer(const std::string& path, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {path, "--port", "0", "--host", "127.0.0.1",
                                     "--max-streams", "64", "--threads", "96"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argp;
    for (std::string& a : args) argp.push_back(a.data());
    argp.push_back(nullptr);
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    const int rc = posix_spawn(&pid_, path.c_str(), &actions, nullptr, argp.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (rc != 0) throw std::runtime_error("cannot start " + path + ": " + std::strerror(rc));
    // Its stdout until "Myriad listening on http://HOST:PORT" (a large scene takes a while).
    std::string received;
    const auto deadline = Clock::now() + std::chrono::minutes(5);
    while (Clock::now() < deadline) {
      const size_t at = received.find("http://");
      if (at != std::string::npos && received.find('\n', at) != std::string::npos) {
        url_ = received.substr(at, received.find('\n', at) - at);
        break;
      }
      pollfd p{fds[0], POLLIN, 0};
      if (poll(&p, 1, 1000) < 0 && errno != EINTR) break;
      char buffer[512];
      const ssize_t n = read(fds[0], buffer, sizeof buffer);
      if (n == 0) break;
      if (n > 0) received.append(buffer, size_t(n));
    }
    close(fds[0]);
    if (url_.empty()) {
      stop();
      throw std::runtime_error(path + " did not start listening (its stderr says why)");
    }
  }
  ~StartedServer() { stop(); }
  const std::string& url() const { return url_; }

 private:
  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  pid_t pid_ = -1;
  std::string url_;
};

std::unique_ptr<httplib::Client> clientFor(const std::string& url) {
  auto client = std::make_unique<httplib::Client>(url);
  client->set_keep_alive(true);
  client->set_read_timeout(600, 0);
  client->set_write_timeout(60, 0);
  client->set_connection_timeout(10, 0);
  return client;
}

struct Session {
  std::string id;
  std::string token;
};

namespace routes = myriad::protocol::routes;

// A route template of protocol/constants.h with the session id filled in.
std::string route(std::string_view pattern, const std::string& id) {
  std::string path(pattern);
  const size_t at = path.find("{id}");
  if (at != std::string::npos) path.replace(at, 4, id);
  return path;
}

json checkedJson(const httplib::Result& res, int status, const std::string& what) {
  if (!res) throw std::runtime_error(what + ": no answer (" + httplib::to_string(res.error()) + ")");
  if (res->status != status) {
    throw std::runtime_error(what + ": " + std::to_string(res->status) + " " + res->body);
  }
  return res->body.empty() ? json() : json::parse(res->body);
}

Session createSession(httplib::Client& client, const Options& o, uint32_t seed) {
  json created = checkedJson(client.Post(std::string(routes::kSessions), "{}", "application/json"),
                             201, "POST sessions");
  Session s{created["id"].get<std::string>(), created["token"].get<std::string>()};
  const httplib::Headers auth = {{"Authorization", "Bearer " + s.token}};
  json generate = {{"count", o.lights}, {"seed", seed}, {"radius", {o.radiusMin, o.radiusMax}}};
  checkedJson(client.Post(route(routes::kSessionLightsGenerate, s.id), auth, generate.dump(),
                          "application/json"),
              200, "POST lights/generate");
  checkedJson(client.Patch(route(routes::kSessionSettings, s.id), auth,
                           R"({"markers": false, "animate": true})", "application/json"),
              200, "PATCH settings");
  return s;
}

std::string frameQuery(const Options& o, const Size& size) {
  return "format=jpeg&quality=" + std::to_string(o.quality) + "&width=" + std::to_string(size.width) +
         "&height=" + std::to_string(size.height);
}

double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const size_t at = std::min(values.size() - 1, size_t(p * double(values.size() - 1) + 0.5));
  return values[at];
}

// One JPEG frame, request to last byte, on one kept-alive connection.
json measureRequests(const std::string& url, const Options& o, const Session& s) {
  auto client = clientFor(url);
  const httplib::Headers auth = {{"Authorization", "Bearer " + s.token}};
  const std::string path = route(routes::kSessionFrame, s.id) + "?" + frameQuery(o, o.size);
  std::vector<double> ms;
  size_t bytes = 0;
  std::string timing;
  for (uint32_t i = 0; i < o.requests + 3; ++i) {
    const auto start = Clock::now();
    httplib::Result res = client->Get(path, auth);
    const double elapsed = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    if (!res || res->status != 200) {
      throw std::runtime_error("GET frame: " + (res ? std::to_string(res->status) + " " + res->body
                                                    : httplib::to_string(res.error())));
    }
    if (i < 3) continue;  // warm-up: targets, pipelines, lists
    ms.push_back(elapsed);
    bytes = res->body.size();
    timing = res->get_header_value("Server-Timing");
  }
  return {{"size", o.size.text()},         {"count", ms.size()},
          {"medianMs", percentile(ms, 0.5)}, {"p90Ms", percentile(ms, 0.9)},
          {"minMs", percentile(ms, 0.0)},    {"bytes", bytes},
          {"serverTiming", timing}};
}

// Reads one stream for `seconds`, counting parts by their Content-Length (a proper multipart
// parse: image bytes are never searched for headers).
struct StreamCount {
  uint64_t frames = 0;  // parts with a new X-Myriad-Frame
  uint64_t bytes = 0;
  double firstAt = 0.0, lastAt = 0.0;  // seconds since the start, of the first and last part
  std::string error;
  // Parts per second between the first part and the last; with fewer than two parts (a device
  // slower than the window), the parts over the whole window.
  double fps(double window) const {
    if (frames > 1 && lastAt > firstAt) return double(frames - 1) / (lastAt - firstAt);
    return double(frames) / window;
  }
};

StreamCount readStream(const std::string& url, const Options& o, const Session& s, const Size& size,
                       Clock::time_point start, Clock::time_point end) {
  StreamCount count;
  auto client = clientFor(url);
  const httplib::Headers auth = {{"Authorization", "Bearer " + s.token}};
  const std::string path = route(routes::kSessionStream, s.id) + "?fps=240&" + frameQuery(o, size);
  std::string buffer;
  size_t need = 0;  // body bytes of the current part still to skip
  std::string lastSequence;
  auto onData = [&](const char* data, size_t length) {
    buffer.append(data, length);
    for (;;) {
      if (need > 0) {
        const size_t take = std::min(need, buffer.size());
        buffer.erase(0, take);
        need -= take;
        if (need > 0) break;
        continue;
      }
      const size_t headersEnd = buffer.find("\r\n\r\n");
      if (headersEnd == std::string::npos) break;
      const std::string headers = buffer.substr(0, headersEnd);
      buffer.erase(0, headersEnd + 4);
      const size_t lengthAt = headers.find("Content-Length: ");
      if (lengthAt == std::string::npos) continue;  // the opening boundary line
      need = std::strtoull(headers.c_str() + lengthAt + 16, nullptr, 10);
      const size_t sequenceAt = headers.find("X-Myriad-Frame: ");
      std::string sequence;
      if (sequenceAt != std::string::npos) {
        sequence = headers.substr(sequenceAt + 16, headers.find("\r\n", sequenceAt) - sequenceAt - 16);
      }
      const double at = std::chrono::duration<double>(Clock::now() - start).count();
      if (sequence != lastSequence) {
        lastSequence = sequence;
        if (count.frames == 0) count.firstAt = at;
        count.lastAt = at;
        ++count.frames;
        count.bytes += need;
      }
    }
    return Clock::now() < end;
  };
  httplib::Result res = client->Get(path, auth, [&](const httplib::Response& r) {
    if (r.status != 200) count.error = "stream answered " + std::to_string(r.status);
    return r.status == 200;
  }, onData);
  // Ending the read ourselves is how a stream measurement ends: httplib reports it as canceled.
  if (!res && res.error() != httplib::Error::Canceled && count.error.empty()) {
    count.error = httplib::to_string(res.error());
  }
  return count;
}

// The session's stats `pipeline` (null when it has none).
json pipelineOf(const std::string& url, const Session& s) {
  auto client = clientFor(url);
  const httplib::Headers auth = {{"Authorization", "Bearer " + s.token}};
  json stats = checkedJson(client->Get(route(routes::kSessionStats, s.id), auth), 200, "GET stats");
  return stats.value("pipeline", json());
}

json measureStreams(const std::string& url, const Options& o, const std::vector<Session>& sessions,
                    const Size& size) {
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(o.seconds));
  std::vector<StreamCount> counts(sessions.size());
  std::vector<std::thread> readers;
  for (size_t i = 0; i < sessions.size(); ++i) {
    readers.emplace_back([&, i] { counts[i] = readStream(url, o, sessions[i], size, start, end); });
  }
  for (std::thread& t : readers) t.join();
  json perStream = json::array();
  json perStreamFrames = json::array();
  double total = 0.0;
  uint64_t bytes = 0, frames = 0;
  for (const StreamCount& c : counts) {
    if (!c.error.empty()) throw std::runtime_error("stream: " + c.error);
    perStream.push_back(c.fps(o.seconds));
    perStreamFrames.push_back(c.frames);
    total += c.fps(o.seconds);
    bytes += c.bytes;
    frames += c.frames;
  }
  const double mean = total / double(counts.size());
  double deviation = 0.0;
  for (const StreamCount& c : counts) {
    if (mean > 0.0) {
      deviation = std::max(deviation, std::abs(c.fps(o.seconds) - mean) / mean * 100.0);
    }
  }
  json result = {{"size", size.text()},
                 {"streams", counts.size()},
                 {"seconds", o.seconds},
                 {"totalFps", total},
                 {"perStreamFps", perStream},
                 {"perStreamFrames", perStreamFrames},
                 {"maxDeviationPercent", deviation},
                 {"bytesPerFrame", frames ? bytes / frames : 0}};
  json pipelines = json::array();
  for (const Session& s : sessions) pipelines.push_back(pipelineOf(url, s));
  if (sessions.size() == 1) {
    result["pipeline"] = pipelines[0];
  } else {
    result["perStreamPipeline"] = pipelines;
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  try {
    std::unique_ptr<StartedServer> started;
    std::string url = o.url;
    if (url.empty()) {
      std::string server = o.server;
      if (server.empty()) {
        // Default: myriad-server next to this binary (a pack), else in the build tree.
        std::string self = argv[0];
        const size_t slash = self.rfind('/');
        const std::string dir = slash == std::string::npos ? "." : self.substr(0, slash);
        server = access((dir + "/myriad-server").c_str(), X_OK) == 0 ? dir + "/myriad-server"
                                                                     : dir + "/../myriad-server";
      }
      started = std::make_unique<StartedServer>(server, o.serverArgs);
      url = started->url();
    }
    auto client = clientFor(url);
    json info = checkedJson(client->Get(std::string(routes::kInfo)), 200, "GET info");
    std::fprintf(stderr, "myriad-stream-bench: %s, %u lights per session\n", url.c_str(), o.lights);

    std::vector<Session> sessions;
    for (uint32_t i = 0; i < std::max(1u, o.streams); ++i) {
      sessions.push_back(createSession(*client, o, i + 1));
    }
    json report = {{"url", url}, {"device", info.value("device", json())}, {"lights", o.lights},
                   {"radius", {o.radiusMin, o.radiusMax}}, {"quality", o.quality},
                   {"serverArgs", o.serverArgs}};
    std::fprintf(stderr, "  request %s...\n", o.size.text().c_str());
    report["request"] = measureRequests(url, o, sessions[0]);
    std::fprintf(stderr, "  one stream %s...\n", o.size.text().c_str());
    report["stream"] = measureStreams(url, o, {sessions[0]}, o.size);
    if (o.streams > 1) {
      std::fprintf(stderr, "  %u streams %s...\n", o.streams, o.size.text().c_str());
      report["streams"] = measureStreams(url, o, sessions, o.size);
    }
    if (o.large) {
      std::fprintf(stderr, "  one stream %s...\n", o.large->text().c_str());
      report["large"] = measureStreams(url, o, {sessions[0]}, *o.large);
    }
    // With the server's --validate: the messages its Vulkan validation reported during the run.
    report["validation"] =
        checkedJson(client->Get(std::string(routes::kInfo)), 200, "GET info").value("validation", json());
    const std::string text = report.dump(2);
    std::cout << text << std::endl;
    if (!o.json.empty()) std::ofstream(o.json) << text << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-stream-bench: %s\n", e.what());
    return 1;
  }
}
