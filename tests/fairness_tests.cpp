// Fairness under any work (issue 31): another session's small frame is answered within 2 s
// beside a heavy frame of any technique and size, because the renderer records a heavy frame as
// bounded submissions and the render thread runs other sessions' frames between them
// (render::Renderer::SplitFrame); a frame that would take the renderer longer than
// --max-frame-seconds is stopped with 413 limit-exceeded naming maxFrameSeconds. Server-Timing's
// `queue` and /metrics' myriad_frame_queue_seconds report the real wait: behind the heavy
// frame's submissions too, not only the render thread's queue.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "api_client.h"
#include "server_process.h"
#include "server_timing.h"

namespace {

using myriad::test::ApiClient;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using Clock = std::chrono::steady_clock;

constexpr double kLightFrameBoundMs = 2000.0;  // the issue's bound for the small frame
// Server-Timing's queue against the wait the client measured: its time less the frame's own
// passes and encoding (Server-Timing's other entries) and less its own host work that
// Server-Timing does not list (the HTTP exchange, recording the commands, reading the pixels
// back; the median of the same frame asked for alone, 5-20 ms with validation on lavapipe).
// Within 10%, and an allowance for contention: on lavapipe the heavy frame's parts are CPU work
// on the same 2 cores, so the small frame's own host work (not listed in Server-Timing, measured
// alone) takes up to 30-40 ms longer beside it (seen with a browser test running alongside); on a
// quiet machine queue and wait agreed within 10 ms.
constexpr double kQueueTolerance = 0.10;
constexpr double kJitterMs = 50.0;
// The heavy frames may take the renderer this long, their parts together (--max-frame-seconds):
// long enough for the small frames to be measured beside them (a frame projected past it is
// stopped only after a tenth of it), short enough for the CTest.
constexpr const char* kFrameBudgetSeconds = "40";
constexpr const char* kLight = "/frame?format=jpeg&width=160&height=90";

// Server-Timing as name -> milliseconds (entries with a duration).
std::map<std::string, double> timings(const Reply& reply) {
  std::map<std::string, double> out;
  for (const std::string& entry : myriad::test::serverTimingEntries(reply.header("Server-Timing"))) {
    const size_t dur = entry.find(";dur=");
    if (dur == std::string::npos) continue;
    out[entry.substr(0, dur)] += std::stod(entry.substr(dur + 5));
  }
  return out;
}

// /metrics' myriad_frame_queue_seconds_sum and _count.
std::pair<double, double> queueMetric(ApiClient& api) {
  const Reply metrics = api.get("/metrics");
  REQUIRE(metrics.status == 200);
  double sum = -1.0;
  double count = -1.0;
  std::istringstream lines(metrics.body);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("myriad_frame_queue_seconds_sum ", 0) == 0) sum = std::stod(line.substr(31));
    if (line.rfind("myriad_frame_queue_seconds_count ", 0) == 0) count = std::stod(line.substr(33));
  }
  REQUIRE(sum >= 0.0);
  REQUIRE(count >= 0.0);
  return {sum, count};
}

struct LightFrame {
  double totalMs = 0.0;  // what the client waited for it
  double queueMs = -1.0;  // Server-Timing's queue
  double ownMs = 0.0;     // its passes and encoding (Server-Timing's other entries)
  bool besideHeavy = false;  // the heavy frame was still rendering when it was answered
  double hostMs = 0.0;       // its own host work (the median of the frame asked for alone)
  double waitMs() const { return totalMs - ownMs - hostMs; }
};

// A 160x90 frame of `light`, timed, with Server-Timing read.
LightFrame lightFrame(ApiClient& api, const TestSession& light) {
  const auto start = Clock::now();
  const Reply frame = api.get(light.path() + kLight, light.token);
  LightFrame f;
  f.totalMs = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  CHECK(frame.status == 200);
  CHECK(frame.header("Content-Type") == "image/jpeg");
  CHECK(frame.body.size() > 500);
  const std::map<std::string, double> t = timings(frame);
  CHECK(t.contains("queue"));
  for (const auto& [name, ms] : t) {
    if (name == "queue") {
      f.queueMs = ms;
    } else {
      f.ownMs += ms;
    }
  }
  return f;
}

// The small frame's own host work, alone: after one frame that makes what a session's first
// frame makes (targets, specialised pipelines), the median of three of (time - Server-Timing).
double hostWorkAlone(ApiClient& api, const TestSession& light) {
  lightFrame(api, light);
  std::vector<double> host;
  for (int i = 0; i < 3; ++i) {
    const LightFrame f = lightFrame(api, light);
    host.push_back(f.totalMs - f.ownMs - f.queueMs);
  }
  std::sort(host.begin(), host.end());
  MESSAGE("the 160x90 frame alone: " << host[1] << " ms of host work besides its passes");
  return std::max(host[1], 0.0);
}

struct Beside {
  std::vector<LightFrame> light;
  Reply heavy;
  double heavySeconds = 0.0;
  double heavyStartedAfterS = 0.0;  // when the first small frame was asked for
};

// Asks for `heavyQuery` of `heavy` on a thread of its own; once it renders, asks for 160x90
// JPEG frames of `light`, 300 ms apart (so that they meet the heavy frame's every phase), until
// the heavy frame is answered (at most 12), then waits for the heavy frame's answer. `hostMs`:
// the small frame's own host work (hostWorkAlone).
Beside besideHeavy(const ServerProcess& server, ApiClient& api, const TestSession& heavy,
                   const std::string& heavyQuery, const TestSession& light, double hostMs) {
  Beside out;
  std::atomic<bool> heavyAnswered{false};
  const auto heavyStart = Clock::now();
  std::thread heavyRequest([&] {
    ApiClient own(server);
    out.heavy = own.get(heavy.path() + heavyQuery, heavy.token);
    out.heavySeconds = std::chrono::duration<double>(Clock::now() - heavyStart).count();
    heavyAnswered = true;
  });
  // Its first parts (the passes before the lighting) are under way.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  out.heavyStartedAfterS = std::chrono::duration<double>(Clock::now() - heavyStart).count();
  for (int i = 0; i < 12 && !heavyAnswered.load(); ++i) {
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(300));
    LightFrame f = lightFrame(api, light);
    f.besideHeavy = !heavyAnswered.load();
    f.hostMs = hostMs;
    out.light.push_back(f);
  }
  heavyRequest.join();
  return out;
}

// What every scenario checks of the small frames: answered within the bound, at least `wanted`
// of them while the heavy frame rendered, and Server-Timing's queue the wait the client saw.
void checkLightFrames(const Beside& b, int wanted, const std::string& what) {
  std::ostringstream list;
  int beside = 0;
  double queueSum = 0.0;
  double waitSum = 0.0;
  for (const LightFrame& f : b.light) {
    list << "\n  " << f.totalMs << " ms (queue " << f.queueMs << " ms, measured wait " << f.waitMs()
         << " ms, own passes and encoding " << f.ownMs << " ms, host " << f.hostMs << " ms)"
         << (f.besideHeavy ? "" : " after the heavy frame was answered");
    if (f.besideHeavy) ++beside;
    queueSum += f.queueMs;
    waitSum += f.waitMs();
  }
  MESSAGE("160x90 frames of another session beside " << what << ", asked from "
                                                     << b.heavyStartedAfterS << " s:" << list.str()
                                                     << "\nqueue " << queueSum
                                                     << " ms in all, measured wait " << waitSum
                                                     << " ms; the heavy request was answered "
                                                     << b.heavySeconds << " s after it was sent, "
                                                     << b.heavy.status);
  CHECK(beside >= wanted);  // otherwise the bound below proves nothing
  // Each frame's queue matches its measured wait, but for at most one: a frame whose host work
  // ran while the heavy frame's parts had both cores (seen up to 106 ms apart, 1 run in 4, with
  // a browser test alongside). Which one and by how much is in the list above.
  int apart = 0;
  for (const LightFrame& f : b.light) {
    CHECK(f.totalMs < kLightFrameBoundMs);
    if (std::abs(f.queueMs - f.waitMs()) > kQueueTolerance * f.waitMs() + kJitterMs) ++apart;
  }
  CHECK(apart <= 1);
  // The real wait, not the render queue's bookkeeping alone (which said 0.05-0.3 ms for waits of
  // seconds): over the frames, queue accounts for the measured wait, whatever each frame's jitter.
  CHECK(queueSum >= (1.0 - kQueueTolerance) * waitSum - kJitterMs * double(b.light.size()));
  CHECK(queueSum <= (1.0 + kQueueTolerance) * waitSum + kJitterMs);
}

// The heavy frame stopped by the frame budget: 413 limit-exceeded naming maxFrameSeconds.
void checkBudgetProblem(const Reply& reply, const std::string& what) {
  checkProblem(reply, 413, "limit-exceeded", what, std::nullopt, "maxFrameSeconds");
  CHECK(reply.json.value("detail", "").find("budget of 40.0 s") != std::string::npos);
}

// A session with `count` generated lights, `technique`, no markers; and a plain one.
struct Sessions {
  TestSession heavy;
  TestSession light;
};
Sessions sessionsFor(ApiClient& api, uint32_t count, const std::string& technique) {
  Sessions s{createSession(api), createSession(api)};
  if (count > 0) {
    const auto start = Clock::now();
    const Reply generated =
        api.post(s.heavy.path() + "/lights/generate",
                 R"({"count": )" + std::to_string(count) + R"(, "seed": 3})", s.heavy.token);
    REQUIRE(generated.status == 200);
    REQUIRE(generated.json["total"].get<uint64_t>() == count);
    MESSAGE(count << " lights generated and uploaded in "
                  << std::chrono::duration<double>(Clock::now() - start).count() << " s");
  }
  for (const TestSession* t : {&s.heavy, &s.light}) {
    REQUIRE(api.patch(t->path() + "/settings", R"({"markers": false})", t->token).status == 200);
  }
  REQUIRE(api.patch(s.heavy.path() + "/settings", R"({"technique": ")" + technique + R"("})",
                    s.heavy.token)
              .status == 200);
  return s;
}

// /metrics' queue histogram grew by the frames answered, with their Server-Timing queue.
void checkQueueMetric(std::pair<double, double> before, std::pair<double, double> after,
                      const Beside& b, std::optional<double> heavyQueueMs) {
  double queueMs = 0.0;
  for (const LightFrame& f : b.light) queueMs += f.queueMs;
  double frames = double(b.light.size());
  if (heavyQueueMs) {
    queueMs += *heavyQueueMs;
    frames += 1.0;
  }
  MESSAGE("myriad_frame_queue_seconds grew by " << (after.first - before.first) * 1000.0
                                                << " ms over " << after.second - before.second
                                                << " frames; Server-Timing said " << queueMs
                                                << " ms over " << frames);
  CHECK(after.second - before.second == frames);
  // Server-Timing rounds each to a microsecond.
  CHECK(std::abs((after.first - before.first) * 1000.0 - queueMs) <= 0.01 * frames + 0.01);
}

void stopCleanly(ServerProcess& server, ApiClient& api) {
  CHECK(myriad::test::validationMessages(api) == 0);
  std::optional<myriad::test::ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  CHECK(status->cleanExit());
}

}  // namespace

TEST_CASE("fairness: a 1,000,000-light clustered frame at 320x180 does not hold another session's frame") {
  // On lavapipe it takes a minute or more: assigning the lights (its passes over them in ranges)
  // takes seconds, and each 16x16 tile walks lists of ~100,000 lights (0.2-0.6 s a tile).
  ServerProcess server({"--lights", "8", "--max-frame-seconds", kFrameBudgetSeconds});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const Sessions s = sessionsFor(api, 1000000, "clustered");
  const double hostMs = hostWorkAlone(api, s.light);
  const auto before = queueMetric(api);
  const Beside b = besideHeavy(server, api, s.heavy, "/frame?format=jpeg&width=320&height=180",
                               s.light, hostMs);
  checkLightFrames(b, 3, "a 1,000,000-light clustered frame at 320x180");
  // Its parts measured, the frame is stopped once it has taken a tenth of the budget.
  checkBudgetProblem(b.heavy, "the clustered frame over the budget");
  checkQueueMetric(before, queueMetric(api), b, std::nullopt);
  stopCleanly(server, api);
}

TEST_CASE("fairness: a 1,000,000-light volumes frame at 1920x1080 does not hold another session's frame") {
  // Each light volume covers thousands of pixels at 1080p (about 4 ms a light on lavapipe): the
  // whole frame would take over an hour. Ranges of a few dozen lights each.
  ServerProcess server({"--lights", "8", "--max-frame-seconds", kFrameBudgetSeconds});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const Sessions s = sessionsFor(api, 1000000, "volumes");
  const double hostMs = hostWorkAlone(api, s.light);
  const auto before = queueMetric(api);
  const Beside b = besideHeavy(server, api, s.heavy, "/frame?format=jpeg&width=1920&height=1080",
                               s.light, hostMs);
  checkLightFrames(b, 3, "a 1,000,000-light volumes frame at 1920x1080");
  checkBudgetProblem(b.heavy, "the volumes frame over the budget");
  checkQueueMetric(before, queueMetric(api), b, std::nullopt);
  stopCleanly(server, api);
}

TEST_CASE("fairness: a 4096x4096 frame does not hold another session's frame, and is answered") {
  // 3-8 s on lavapipe: the G-buffer, the light assignment, the shading in ranges of tiles, the
  // final pass in ranges of workgroups, anti-aliasing and the readback, each in bounded parts.
  ServerProcess server({"--lights", "8", "--max-resolution", "4096", "--max-frame-seconds",
                        kFrameBudgetSeconds});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const Sessions s = sessionsFor(api, 0, "clustered");
  const double hostMs = hostWorkAlone(api, s.light);
  const auto before = queueMetric(api);
  const Beside b = besideHeavy(server, api, s.heavy, "/frame?format=jpeg&width=4096&height=4096",
                               s.light, hostMs);
  checkLightFrames(b, 2, "a 4096x4096 frame");
  REQUIRE(b.heavy.status == 200);
  CHECK(b.heavy.header("Content-Type") == "image/jpeg");
  // The JPEG's frame header (SOF0..SOF2): height, then width, big-endian.
  const std::string& jpeg = b.heavy.body;
  uint32_t width = 0;
  uint32_t height = 0;
  for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
    const auto marker = uint8_t(jpeg[i + 1]);
    if (uint8_t(jpeg[i]) == 0xFF && marker >= 0xC0 && marker <= 0xC2) {
      height = uint32_t(uint8_t(jpeg[i + 5])) << 8 | uint8_t(jpeg[i + 6]);
      width = uint32_t(uint8_t(jpeg[i + 7])) << 8 | uint8_t(jpeg[i + 8]);
      break;
    }
  }
  CHECK(width == 4096u);
  CHECK(height == 4096u);
  const std::map<std::string, double> heavyTimings = timings(b.heavy);
  REQUIRE(heavyTimings.contains("queue"));
  checkQueueMetric(before, queueMetric(api), b, heavyTimings.at("queue"));
  stopCleanly(server, api);
}
