// CPU-only tests of the frame routes' pieces: session frame and stream queries, the metrics
// exposition, the multipart framing and slots of streams, frame encoding and per-session stats.
#include <doctest/doctest.h>

#include <atomic>
#include <cstring>
#include <future>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "encode/video.h"
#include "render/render_queue.h"
#include "service/frame_query.h"
#include "service/interactive_quality.h"
#include "service/metrics.h"
#include "service/shared_frames.h"
#include "service/session_frames.h"
#include "service/stream.h"

using namespace myriad;
using service::FrameQueryError;
using service::FrameRequest;
using service::ImageFormat;

namespace {

struct Failure {
  std::string parameter;
  std::string detail;
  bool unknown = false;
};

template <typename Parse>
Failure failureOf(Parse parse) {
  try {
    parse();
  } catch (const FrameQueryError& e) {
    return {e.parameter(), e.what(), e.unknownParameter()};
  }
  return {};
}

}  // namespace

TEST_CASE("session frame query: defaults, formats, time, token") {
  FrameRequest bare = service::parseSessionFrameQuery({}, 2048);
  CHECK(bare.format == ImageFormat::Png);
  CHECK(bare.quality == service::kDefaultJpegQuality);
  CHECK(bare.settings.width == 1280);
  CHECK(bare.settings.height == 720);
  CHECK_FALSE(bare.settings.raw);
  CHECK_FALSE(bare.time.has_value());

  FrameRequest raw = service::parseSessionFrameQuery(
      {{"format", "raw"}, {"target", "depth"}, {"width", "64"}, {"height", "32"},
       {"time", "2.5"}, {"token", "abc"}},
      2048);
  CHECK(raw.format == ImageFormat::Raw);
  CHECK(raw.settings.raw);
  CHECK(raw.settings.target == render::Target::Depth);
  CHECK(raw.settings.width == 64);
  CHECK(raw.settings.height == 32);
  REQUIRE(raw.time.has_value());
  CHECK(*raw.time == doctest::Approx(2.5));

  FrameRequest jpeg = service::parseSessionFrameQuery({{"format", "jpeg"}, {"quality", "40"}}, 64);
  CHECK(jpeg.format == ImageFormat::Jpeg);
  CHECK(jpeg.quality == 40);
  CHECK(jpeg.settings.width == 64);  // the default shrinks to the server's maximum
  CHECK(jpeg.settings.height == 36);

  struct Case {
    std::multimap<std::string, std::string> params;
    std::string parameter;
    bool unknown = false;
  };
  const Case cases[] = {
      {{{"format", "gif"}}, "format"},
      {{{"format", "PNG"}}, "format"},
      {{{"quality", "0"}}, "quality"},
      {{{"quality", "101"}}, "quality"},
      {{{"quality", "50.5"}}, "quality"},
      {{{"quality", ""}}, "quality"},
      {{{"time", "-0.5"}}, "time"},
      {{{"time", "nan"}}, "time"},
      {{{"time", "2e6"}}, "time"},
      {{{"width", "4096"}}, "width"},
      {{{"fps", "10"}}, "fps", true},
      {{{"look_at", "1,2"}}, "look_at"},  // a camera for one frame: checked like GET /v1/frame's
      {{{"up", "0,nan,1"}}, "up"},
      {{{"fov", "180"}}, "fov"},
      {{{"near", "0"}}, "near"},
      {{{"far", "-1"}}, "far"},
      {{{"look", "1,2,3"}}, "look", true},
      {{{"time", "1"}, {"time", "2"}}, "time"},
  };
  for (const Case& c : cases) {
    INFO("parameter ", c.parameter);
    Failure failure = failureOf([&] { service::parseSessionFrameQuery(c.params, 2048); });
    CHECK(failure.parameter == c.parameter);
    CHECK(failure.unknown == c.unknown);
    CHECK(failure.detail.find(c.parameter) != std::string::npos);
  }
  Failure unknown = failureOf([] { service::parseSessionFrameQuery({{"zoom", "2"}}, 2048); });
  CHECK(unknown.detail.find("/v1/sessions/{id}/frame takes target, format") != std::string::npos);
}

TEST_CASE("stream query: jpeg by default, png allowed, raw not, fps bounded") {
  FrameRequest bare = service::parseStreamQuery({}, 2048);
  CHECK(bare.format == ImageFormat::Jpeg);
  CHECK(bare.fps == service::kDefaultStreamFps);
  CHECK(service::parseStreamQuery({{"format", "png"}, {"fps", "240"}}, 2048).fps == 240);
  CHECK(service::parseStreamQuery({{"fps", "1"}}, 2048).fps == 1);
  CHECK(failureOf([] { service::parseStreamQuery({{"format", "raw"}}, 2048); }).parameter ==
        "format");
  CHECK(failureOf([] { service::parseStreamQuery({{"fps", "0"}}, 2048); }).parameter == "fps");
  CHECK(failureOf([] { service::parseStreamQuery({{"fps", "241"}}, 2048); }).parameter == "fps");
  Failure time = failureOf([] { service::parseStreamQuery({{"time", "1"}}, 2048); });
  CHECK(time.parameter == "time");
  CHECK(time.unknown);
}

TEST_CASE("stream query: codec makes a video stream with a bitrate; image members refused") {
  CHECK_FALSE(service::parseStreamQuery({}, 2048).video.has_value());
  FrameRequest vp8 = service::parseStreamQuery(
      {{"codec", "vp8"}, {"width", "1920"}, {"height", "1080"}, {"fps", "30"}}, 2048);
  REQUIRE(vp8.video.has_value());
  CHECK(vp8.video->codec == encode::VideoCodec::Vp8);
  CHECK(vp8.video->bitrateKbps == 6220);  // 0.1 bit per pixel per frame
  FrameRequest vp9 = service::parseStreamQuery({{"codec", "vp9"}, {"bitrate", "800"}}, 2048);
  REQUIRE(vp9.video.has_value());
  CHECK(vp9.video->codec == encode::VideoCodec::Vp9);
  CHECK(vp9.video->bitrateKbps == 800);
  // Tiny streams get the protocol's least bitrate.
  CHECK(service::parseStreamQuery({{"codec", "vp8"}, {"width", "8"}, {"height", "8"}}, 2048)
            .video->bitrateKbps == protocol::query::kMinBitrateKbps);
  struct Case {
    std::multimap<std::string, std::string> params;
    std::string parameter;
    std::string says;
  };
  const Case cases[] = {
      {{{"codec", "av1"}}, "codec", "is not one of: vp8, vp9, h264"},
      {{{"codec", "vp8"}, {"format", "jpeg"}}, "format", "takes bitrate instead"},
      {{{"codec", "vp9"}, {"quality", "80"}}, "quality", "takes bitrate instead"},
      {{{"codec", "vp8"}, {"bitrate", "49"}}, "bitrate", "from 50 to 100000"},
      {{{"codec", "vp8"}, {"bitrate", "100001"}}, "bitrate", "from 50 to 100000"},
      {{{"codec", "vp8"}, {"width", "1"}}, "width", "at least 2"},
      {{{"bitrate", "1000"}}, "bitrate", "name a codec"},
      {{{"codec", "vp8"}, {"codec", "vp9"}}, "codec", "more than once"},
  };
  for (const Case& c : cases) {
    INFO("parameter ", c.parameter, ", expecting: ", c.says);
    Failure failure = failureOf([&] { service::parseStreamQuery(c.params, 2048); });
    CHECK(failure.parameter == c.parameter);
    CHECK(failure.detail.find(c.says) != std::string::npos);
  }
}

TEST_CASE("GET /v1/frame takes format and quality") {
  service::FrameDefaults defaults;
  defaults.camera.eye = {0.0f, 2.0f, 6.0f};
  defaults.maxResolution = 1024;
  FrameRequest request =
      service::parseFrameRequest({{"format", "jpeg"}, {"quality", "90"}, {"fov", "45"}}, defaults);
  CHECK(request.format == ImageFormat::Jpeg);
  CHECK(request.quality == 90);
  CHECK(request.settings.camera.fovYDegrees == doctest::Approx(45.0f));
  CHECK(service::parseFrameRequest({{"format", "raw"}}, defaults).settings.raw);
  CHECK(failureOf([&] { service::parseFrameRequest({{"time", "1"}}, defaults); }).unknown);
}

TEST_CASE("metrics exposition: with --node-id every series carries node, comments do not") {
  service::Metrics metrics;
  metrics.countRequest("/v1/health", 200);
  metrics.observeFrame(0.2);
  metrics.setNodeLabel("7");
  const std::string text = metrics.exposition({3, 1, 4096, 0});
  INFO(text);
  CHECK(text.find("myriad_http_requests_total{node=\"7\",route=\"/v1/health\",status=\"200\"} 1\n") !=
        std::string::npos);
  CHECK(text.find("myriad_frame_seconds_bucket{node=\"7\",le=\"0.25\"} 1\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_count{node=\"7\"} 1\n") != std::string::npos);
  CHECK(text.find("myriad_sessions{node=\"7\"} 3\n") != std::string::npos);
  CHECK(text.find("# TYPE myriad_sessions gauge\n") != std::string::npos);
  // Every sample line has it.
  std::istringstream lines(text);
  size_t samples = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line.front() == '#') continue;
    ++samples;
    CHECK_MESSAGE(line.find("{node=\"7\"") != std::string::npos, line);
  }
  CHECK(samples > 20);
}

TEST_CASE("metrics exposition: counters per route template, cumulative histogram, gauges") {
  service::Metrics metrics;
  metrics.countRequest("/v1/sessions/{id}/frame", 200);
  metrics.countRequest("/v1/sessions/{id}/frame", 200);
  metrics.countRequest("/v1/sessions/{id}/frame", 404);
  metrics.countRequest("a\"b\\c", 500);
  metrics.observeFrame(0.003);
  metrics.observeFrame(0.2);
  metrics.observeFrame(100.0);
  CHECK(metrics.requests("/v1/sessions/{id}/frame", 200) == 2);
  CHECK(metrics.requests("/v1/sessions/{id}/frame", 201) == 0);

  const std::string text = metrics.exposition({3, 1, 4096, 0});
  INFO(text);
  CHECK(text.find("# TYPE myriad_http_requests_total counter\n") != std::string::npos);
  CHECK(text.find("myriad_http_requests_total{route=\"/v1/sessions/{id}/frame\",status=\"200\"} 2\n") !=
        std::string::npos);
  CHECK(text.find("myriad_http_requests_total{route=\"/v1/sessions/{id}/frame\",status=\"404\"} 1\n") !=
        std::string::npos);
  CHECK(text.find("route=\"a\\\"b\\\\c\"") != std::string::npos);  // label value escaped
  CHECK(text.find("myriad_frame_seconds_bucket{le=\"0.005\"} 1\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_bucket{le=\"0.1\"} 1\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_bucket{le=\"0.25\"} 2\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_bucket{le=\"30\"} 2\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_bucket{le=\"+Inf\"} 3\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_count 3\n") != std::string::npos);
  CHECK(text.find("myriad_frame_seconds_sum 100.2") != std::string::npos);
  // The queue wait: its own histogram, the same buckets; nothing observed yet.
  CHECK(text.find("# TYPE myriad_frame_queue_seconds histogram\n") != std::string::npos);
  CHECK(text.find("myriad_frame_queue_seconds_count 0\n") != std::string::npos);
  metrics.observeQueueWait(0.04);
  metrics.observeQueueWait(1.5);
  const std::string waits = metrics.exposition({3, 1, 4096, 0});
  CHECK(waits.find("myriad_frame_queue_seconds_bucket{le=\"0.05\"} 1\n") != std::string::npos);
  CHECK(waits.find("myriad_frame_queue_seconds_bucket{le=\"2.5\"} 2\n") != std::string::npos);
  CHECK(waits.find("myriad_frame_queue_seconds_count 2\n") != std::string::npos);
  CHECK(waits.find("myriad_frame_queue_seconds_sum 1.54") != std::string::npos);
  CHECK(waits.find("myriad_frame_seconds_count 3\n") != std::string::npos);
  CHECK(text.find("myriad_sessions 3\n") != std::string::npos);
  CHECK(text.find("myriad_streams 1\n") != std::string::npos);
  CHECK(text.find("myriad_gpu_memory_bytes 4096\n") != std::string::npos);
  CHECK(text.find("myriad_validation_messages_total 0\n") != std::string::npos);
  CHECK(text.back() == '\n');
}

TEST_CASE("stream parts: the contract's framing") {
  CHECK(service::multipartPart("image/jpeg", "JPEG", 7, true) ==
        "--myriad-frame\r\nContent-Type: image/jpeg\r\nContent-Length: 4\r\n"
        "X-Myriad-Frame: 7\r\n\r\nJPEG\r\n--myriad-frame\r\n");
  CHECK(service::multipartPart("image/png", std::string(3, '\0'), 8, false) ==
        std::string("Content-Type: image/png\r\nContent-Length: 3\r\nX-Myriad-Frame: 8\r\n\r\n") +
            std::string(3, '\0') + "\r\n--myriad-frame\r\n");
}

TEST_CASE("stream parts: a stream that ends for a reason says it in a last problem part") {
  const service::Problem revoked = service::unauthorized("Revoked.");
  const std::string body = service::toBody(revoked);
  CHECK(body.find(R"("detail":"Revoked.")") != std::string::npos);
  CHECK(service::problemPart(revoked, false) ==
        "Content-Type: application/problem+json\r\nContent-Length: " +
            std::to_string(body.size()) + "\r\n\r\n" + body + "\r\n--myriad-frame\r\n");
  // Before any frame: the opening boundary too.
  CHECK(service::problemPart(revoked, true) ==
        "--myriad-frame\r\n" + service::problemPart(revoked, false));
}

TEST_CASE("stream parts: an interactive part names its render scale") {
  CHECK(service::multipartPart("image/jpeg", "JPEG", 9, false, "0.4375") ==
        "Content-Type: image/jpeg\r\nContent-Length: 4\r\nX-Myriad-Frame: 9\r\n"
        "X-Myriad-Interactive: 0.4375\r\n\r\nJPEG\r\n--myriad-frame\r\n");
}

TEST_CASE("stream query: interactive is 0 to 60 frames a second, image streams only") {
  CHECK(service::parseStreamQuery({}, 2048).interactiveFps == 0);
  CHECK(service::parseStreamQuery({{"interactive", "24"}}, 2048).interactiveFps == 24);
  CHECK(service::parseStreamQuery({{"interactive", "0"}, {"codec", "vp9"}}, 2048).video);
  for (const char* bad : {"61", "-1", "x", ""}) {
    Failure f = failureOf([bad] { service::parseStreamQuery({{"interactive", bad}}, 2048); });
    CHECK(f.parameter == "interactive");
    CHECK(f.detail.find("0 to 60") != std::string::npos);
  }
  Failure video = failureOf(
      [] { service::parseStreamQuery({{"interactive", "24"}, {"codec", "vp8"}}, 2048); });
  CHECK(video.parameter == "interactive");
  CHECK(video.detail.find("image streams") != std::string::npos);
}

TEST_CASE("interactive quality: degraded while changes come, settles, scale follows frame times") {
  using Q = service::InteractiveQuality;
  using std::chrono::milliseconds;
  const Q::Clock::time_point t0{};
  Q quality(20);  // budget 0.5 / 20 s = 25 ms
  CHECK_FALSE(quality.moving(t0));
  quality.sawChange(t0);
  CHECK(quality.moving(t0 + milliseconds(59)));
  CHECK_FALSE(quality.moving(t0 + milliseconds(60)));  // first change: the shortest settle
  quality.sawChange(t0 + milliseconds(100));             // 100 ms later: settle 200 ms
  CHECK(quality.settle() == milliseconds(200));
  CHECK(quality.moving(t0 + milliseconds(299)));
  CHECK_FALSE(quality.moving(t0 + milliseconds(300)));
  quality.sawChange(t0 + milliseconds(280));             // the longest recent gap counts
  CHECK(quality.settle() == milliseconds(360));
  quality.sawChange(t0 + milliseconds(320));
  CHECK(quality.settle() == milliseconds(360));          // 40 ms, but 180 was recent
  for (int i = 2; i <= 4; ++i) quality.sawChange(t0 + milliseconds(280 + 40 * i));
  CHECK(quality.settle() == milliseconds(80));           // four 40 ms gaps: the 180 is gone
  quality.sawChange(t0 + milliseconds(5000));            // a new interaction
  CHECK(quality.settle() == Q::kMinSettle);
  quality.sawChange(t0 + milliseconds(5600));            // 600 ms gap: capped at 400
  CHECK(quality.settle() == Q::kMaxSettle);
  // A still that costs 1.2 s (a loaded CPU renderer): at least 300 ms before one is started.
  quality.measuredFull(milliseconds(1200));
  quality.sawChange(t0 + milliseconds(9000));
  CHECK(quality.settle() == milliseconds(300));
  quality.measuredFull(milliseconds(0));                 // not rendered for this stream: kept
  quality.measuredFull(milliseconds(100));               // cheap stills: the gaps decide again
  quality.sawChange(t0 + milliseconds(12000));
  CHECK(quality.settle() == Q::kMinSettle);

  // The request: scaled size, JPEG quality at most 50, flagged; the stream's own untouched.
  FrameRequest full = service::parseStreamQuery({{"width", "1280"}, {"height", "720"},
                                                 {"quality", "90"}}, 2048);
  CHECK(quality.scale(Q::Motion::Steered) == Q::kStartScale);
  FrameRequest cheap = quality.degrade(full, Q::Motion::Steered);
  CHECK(cheap.settings.width == 640);
  CHECK(cheap.settings.height == 360);
  CHECK(cheap.quality == 50);
  CHECK(cheap.interactive);
  CHECK_FALSE(full.interactive);

  // A frame 6.4x over budget at 0.5: the scale goes down (half way to 0.2, in 1/16 steps); within
  // 15% of the budget it stays; far under budget it climbs, never past 1 or below 1/4.
  quality.measured(Q::Motion::Steered, 0.5, milliseconds(160));
  CHECK(quality.scale(Q::Motion::Steered) == doctest::Approx(0.375));
  quality.measured(Q::Motion::Steered, 0.375, milliseconds(27));
  CHECK(quality.scale(Q::Motion::Steered) == doctest::Approx(0.375));
  for (int i = 0; i < 20; ++i) quality.measured(Q::Motion::Steered, quality.scale(Q::Motion::Steered), milliseconds(1));
  CHECK(quality.scale(Q::Motion::Steered) == 1.0);
  for (int i = 0; i < 20; ++i) quality.measured(Q::Motion::Steered, quality.scale(Q::Motion::Steered), milliseconds(5000));
  CHECK(quality.scale(Q::Motion::Steered) == Q::kMinScale);
  FrameRequest tiny = service::parseStreamQuery({{"width", "2"}, {"height", "1"}}, 2048);
  CHECK(quality.degrade(tiny, Q::Motion::Steered).settings.height == 1);  // never 0 pixels

  // At the smallest scales a frame's cost is not proportional to its pixels: 18 ms at 1/8 (under
  // the 25 ms budget by more than 15%) sends it up to 3/16, 30 ms there (over by more) back down,
  // and then it stays at 1/8 instead of alternating, each size remaking the frame targets; after
  // kProbeFrames frames it tries 3/16 again.
  Q small(20);
  small.measured(Q::Motion::Steered, 0.5, milliseconds(5000));  // down to 1/8, past 1/4 only
  small.measured(Q::Motion::Steered, 0.25, milliseconds(5000));
  CHECK(small.scale(Q::Motion::Steered) == Q::kMinScale);
  small.measured(Q::Motion::Steered, Q::kMinScale, milliseconds(18));
  CHECK(small.scale(Q::Motion::Steered) == Q::kMinScale);  // one frame: not yet
  small.measured(Q::Motion::Steered, Q::kMinScale, milliseconds(18));
  CHECK(small.scale(Q::Motion::Steered) == doctest::Approx(0.1875));
  small.measured(Q::Motion::Steered, 0.1875, milliseconds(30));
  CHECK(small.scale(Q::Motion::Steered) == doctest::Approx(0.1875));
  small.measured(Q::Motion::Steered, 0.1875, milliseconds(30));
  CHECK(small.scale(Q::Motion::Steered) == Q::kMinScale);
  for (uint32_t i = 0; i + 1 < Q::kProbeFrames; ++i) {
    small.measured(Q::Motion::Steered, Q::kMinScale, milliseconds(18));
    CHECK(small.scale(Q::Motion::Steered) == Q::kMinScale);
  }
  small.measured(Q::Motion::Steered, Q::kMinScale, milliseconds(18));
  CHECK(small.scale(Q::Motion::Steered) == doctest::Approx(0.1875));

  // One slow frame among fitting ones (the page's own work on the renderer's cores) does not move
  // a steered scale: it moves on the median of the last three frames at that scale.
  Q steady(20);
  steady.measured(Q::Motion::Steered, 0.5, milliseconds(160));  // 6.4x over: at once, to 3/8
  REQUIRE(steady.scale(Q::Motion::Steered) == doctest::Approx(0.375));
  for (int ms : {24, 23, 40, 24, 25, 41, 23, 24}) {
    steady.measured(Q::Motion::Steered, 0.375, milliseconds(ms));
    CHECK(steady.scale(Q::Motion::Steered) == doctest::Approx(0.375));
  }
  steady.measured(Q::Motion::Steered, 0.375, milliseconds(40));
  CHECK(steady.scale(Q::Motion::Steered) == doctest::Approx(0.375));
  steady.measured(Q::Motion::Steered, 0.375, milliseconds(40));  // two of the last three over
  CHECK(steady.scale(Q::Motion::Steered) == doctest::Approx(0.3125));

  // Animation holds half the rate (10 fps: a 50 ms budget) with a scale of its own: a frame of
  // 50 ms at 0.5 keeps 0.5 there, while the steered scale (now at its floor) is untouched.
  CHECK(quality.targetFps(Q::Motion::Animated) == 10);
  CHECK(Q(1).targetFps(Q::Motion::Animated) == 1);
  CHECK(quality.scale(Q::Motion::Animated) == Q::kStartScale);
  quality.measured(Q::Motion::Animated, 0.5, milliseconds(50));
  CHECK(quality.scale(Q::Motion::Animated) == Q::kStartScale);
  quality.measured(Q::Motion::Animated, 0.5, milliseconds(320));  // 6.4x over: down, as steered
  CHECK(quality.scale(Q::Motion::Animated) == doctest::Approx(0.375));
  CHECK(quality.scale(Q::Motion::Steered) == Q::kMinScale);
  CHECK(quality.degrade(full, Q::Motion::Animated).settings.width == 480);
  // 4% over the budget: a steered frame keeps its scale; an animated one holds the budget as a
  // ceiling and steps down, and does not go back up while the larger scale's last frame missed.
  Q steered(20);
  steered.measured(Q::Motion::Steered, 0.5, milliseconds(26));  // 25 ms budget, 4% over
  CHECK(steered.scale(Q::Motion::Steered) == Q::kStartScale);
  quality.measured(Q::Motion::Animated, 0.375, milliseconds(52));
  CHECK(quality.scale(Q::Motion::Animated) == doctest::Approx(0.3125));
  quality.measured(Q::Motion::Animated, 0.3125, milliseconds(38));  // 1.32x under, but 0.375 missed
  CHECK(quality.scale(Q::Motion::Animated) == doctest::Approx(0.3125));
}

TEST_CASE("stream registry: maxStreams places, a session's newest replaces its oldest, none after shutdown") {
  service::StreamRegistry registry(2);
  auto session = std::make_shared<service::Session>("s-0123456789abcdef", std::string(64, 'a'));
  auto other = std::make_shared<service::Session>("s-fedcba9876543210", std::string(64, 'b'));
  auto first = registry.open(session);
  auto second = registry.open(session);
  REQUIRE(first);
  REQUIRE(second);
  CHECK(registry.count() == 2);
  // Full: another session is refused; the same session's third stream replaces its first.
  CHECK_FALSE(registry.open(other));
  auto third = registry.open(session);
  REQUIRE(third);
  CHECK(first->replaced());
  CHECK_FALSE(second->replaced());
  CHECK_FALSE(third->replaced());
  CHECK(registry.count() == 2);
  first.reset();  // the replaced stream ends and gives its entry back
  CHECK(registry.count() == 2);
  CHECK_FALSE(registry.open(other));
  second.reset();
  CHECK(registry.count() == 1);
  auto fromOther = registry.open(other);
  CHECK(fromOther);
  registry.shutdown();
  CHECK(registry.stopping());
  third.reset();
  CHECK_FALSE(registry.open(session));
  fromOther.reset();
  CHECK(registry.count() == 0);
}

TEST_CASE("stream registry: a session holds at most its share; the server's limit still replaces") {
  using Refusal = service::StreamRegistry::Refusal;
  service::StreamRegistry registry(4);
  auto greedy = std::make_shared<service::Session>("s-0123456789abcdef", std::string(64, 'a'));
  auto other = std::make_shared<service::Session>("s-fedcba9876543210", std::string(64, 'b'));
  auto third = std::make_shared<service::Session>("s-00112233445566ff", std::string(64, 'c'));
  Refusal refusal = Refusal::stopping;
  auto first = registry.open(greedy, 2, {}, &refusal);
  CHECK(refusal == Refusal::none);
  auto second = registry.open(greedy, 2, {}, &refusal);
  REQUIRE(first);
  REQUIRE(second);
  // Its share taken, with places left on the server: refused, and nothing of its own replaced.
  CHECK_FALSE(registry.open(greedy, 2, {}, &refusal));
  CHECK(refusal == Refusal::maxStreamsPerSession);
  CHECK_FALSE(first->replaced());
  CHECK(registry.count() == 2);
  // Another session still gets its places.
  auto fromOther = registry.open(other, 2, {}, &refusal);
  CHECK(fromOther);
  CHECK(refusal == Refusal::none);
  auto fromThird = registry.open(third, 2, {}, &refusal);
  CHECK(fromThird);
  CHECK(registry.count() == 4);
  // Full: a session with a stream replaces its own oldest (within its share), others get 429.
  auto replacing = registry.open(other, 2, {}, &refusal);
  REQUIRE(replacing);
  CHECK(fromOther->replaced());
  CHECK(registry.count() == 4);
  auto newcomer = std::make_shared<service::Session>("s-ffeeddccbbaa9988", std::string(64, 'd'));
  CHECK_FALSE(registry.open(newcomer, 2, {}, &refusal));
  CHECK(refusal == Refusal::maxStreams);
  registry.shutdown();
  CHECK_FALSE(registry.open(newcomer, 2, {}, &refusal));
  CHECK(refusal == Refusal::stopping);
}

TEST_CASE("encodeFrame: raw frames carry their size, channels and target; images their type") {
  render::Frame frame;
  frame.width = 2;
  frame.height = 1;
  frame.technique = render::Technique::Tiled;
  frame.passes = {{"gbuffer", 1.5}, {"readback", 0.25}};
  frame.data = {1.5f, 0.0f, 0.0f, 0.0f, 7.25f, 0.0f, 0.0f, 0.0f};  // two depths, 4 floats each

  FrameRequest request;
  request.format = ImageFormat::Raw;
  request.settings.target = render::Target::Depth;
  request.settings.raw = true;
  service::EncodedFrame raw = service::encodeFrame(frame, request);
  CHECK(raw.contentType == "application/octet-stream");
  REQUIRE(raw.body.size() == 2 * sizeof(float));
  float depths[2];
  std::memcpy(depths, raw.body.data(), sizeof depths);
  CHECK(depths[0] == 1.5f);
  CHECK(depths[1] == 7.25f);
  std::map<std::string, std::string> headers(raw.headers.begin(), raw.headers.end());
  CHECK(headers["X-Myriad-Width"] == "2");
  CHECK(headers["X-Myriad-Height"] == "1");
  CHECK(headers["X-Myriad-Channels"] == "depth");
  CHECK(headers["X-Myriad-Target"] == "depth");
  CHECK(headers["X-Myriad-Technique"] == "tiled");
  CHECK(headers["Server-Timing"].starts_with("gbuffer;dur=1.500, readback;dur=0.250, encode;dur="));
  CHECK(headers["Server-Timing"].find("culling;desc=") != std::string::npos);

  frame.rgba.assign(2 * 1 * 4, 200);
  request.format = ImageFormat::Jpeg;
  request.settings.raw = false;
  service::EncodedFrame jpeg = service::encodeFrame(frame, request);
  CHECK(jpeg.contentType == "image/jpeg");
  REQUIRE(jpeg.body.size() > 4);
  CHECK(uint8_t(jpeg.body[0]) == 0xFF);
  CHECK(uint8_t(jpeg.body[1]) == 0xD8);
  request.format = ImageFormat::Png;
  CHECK(service::encodeFrame(frame, request).contentType == "image/png");
  frame.technique = render::Technique::Volumes;  // no light lists: no culling report
  std::map<std::string, std::string> volumes;
  for (auto& [name, value] : service::encodeFrame(frame, request).headers) volumes[name] = value;
  CHECK(volumes["Server-Timing"].find("culling") == std::string::npos);
}

TEST_CASE("frame stats: the last frame per session, counted; entries of sessions gone dropped") {
  service::FrameStatsBook book;
  auto session = std::make_shared<service::Session>("s-00000000000000aa", std::string(64, 'b'));
  protocol::Stats none = book.statsOf(*session, 5, true);
  CHECK_FALSE(none.frame.has_value());
  CHECK_FALSE(none.culling.has_value());
  CHECK(none.frames == 0);
  CHECK(none.lightCount == 5);
  CHECK(none.lightsAnimated);

  render::Frame frame;
  frame.width = 64;
  frame.height = 32;
  frame.passes = {{"gbuffer", 2.0}, {"lighting", 1.0}, {"readback", 0.5}};
  frame.sceneBytes = 4096;
  frame.culling.lightBytes = 512;
  frame.culling.listBytes = 1024;
  frame.culling.listEntries = 77;
  book.record(session, frame, render::Target::Normal, 3.0);
  book.record(session, frame, render::Target::Normal, 3.0);
  protocol::Stats stats = book.statsOf(*session, 5, false);
  REQUIRE(stats.frame.has_value());
  CHECK(stats.frames == 2);
  CHECK(stats.frame->passes.size() == 3);
  CHECK(stats.frame->totalGpuMs == doctest::Approx(3.5));
  CHECK(stats.frame->readbackMs == doctest::Approx(0.5));
  CHECK(stats.frame->encodeMs == doctest::Approx(3.0));
  CHECK(stats.frame->target == "normal");
  CHECK(stats.frame->technique == "clustered");
  REQUIRE(stats.culling.has_value());
  CHECK(stats.culling->listEntries == 77);
  CHECK(stats.gpuMemory.sceneBytes == 4096);
  CHECK(stats.gpuMemory.lightBytes == 512);
  CHECK(stats.gpuMemory.listBytes == 1024);

  // A new session under another id starts from nothing; the old one's entry goes once it is gone.
  auto other = std::make_shared<service::Session>("s-00000000000000bb", std::string(64, 'c'));
  CHECK(book.statsOf(*other, 0, false).frames == 0);
  const std::string oldId = session->id;
  session.reset();
  book.record(other, frame, render::Target::Final, 1.0);
  service::Session again(oldId, std::string(64, 'b'));
  CHECK(book.statsOf(again, 0, false).frames == 0);
}

// ---- Video channels (SharedFrames::joinVideo / nextVideo) against a render queue that makes
// pictures on the CPU: what each viewer of one encoder gets, in which order, and when it skips to
// a key frame.

namespace {

// Renders a picture of the asked size whose colours depend on how many it rendered before.
class PictureQueue final : public render::RenderQueue {
 public:
  const render::DeviceSummary& device() const override { return device_; }
  uint32_t maxDimension() const override { return 4096; }
  uint32_t maxQueuedFrames() const override { return 8; }
  uint32_t validationMessages() const override { return 0; }
  render::SceneId defaultScene() const override { return 0; }
  std::future<render::SceneId> createScene(std::shared_ptr<const scene::Scene>) override {
    return ready<render::SceneId>(1);
  }
  std::future<void> replaceScene(render::SceneId, std::shared_ptr<const scene::Scene>) override {
    return ready();
  }
  std::future<void> destroyScene(render::SceneId) override { return ready(); }
  std::future<void> updateLights(render::SceneId, render::LightUpdate) override { return ready(); }
  std::future<void> updateMaterials(render::SceneId, std::vector<render::MaterialWrite>) override {
    return ready();
  }
  std::future<void> updateInstances(render::SceneId, render::InstanceUpdate) override {
    return ready();
  }
  std::future<void> setEnvironmentImage(render::SceneId,
                                        std::shared_ptr<const scene::EnvironmentImage>) override {
    return ready();
  }
  std::future<render::Frame> submit(render::SceneId, const render::FrameSettings& settings,
                                    render::FrameSource,
                                    std::shared_ptr<const std::atomic<bool>>) override {
    render::Frame frame;
    frame.width = settings.width;
    frame.height = settings.height;
    frame.rgba.resize(size_t(frame.width) * frame.height * 4);
    const uint32_t n = ++rendered;
    for (uint32_t y = 0; y < frame.height; ++y) {
      for (uint32_t x = 0; x < frame.width; ++x) {
        uint8_t* p = &frame.rgba[(size_t(y) * frame.width + x) * 4];
        p[0] = uint8_t((x * 4 + n * 9) & 255);
        p[1] = uint8_t((y * 4 + n * 5) & 255);
        p[2] = uint8_t(((x + y) * 2 + n * 13) & 255);
        p[3] = 255;
      }
    }
    return ready<render::Frame>(std::move(frame));
  }
  uint64_t gpuMemoryBytes() const override { return 0; }
  void stop() override {}

  std::atomic<uint32_t> rendered{0};

 private:
  template <typename T>
  static std::future<T> ready(T value) {
    std::promise<T> promise;
    promise.set_value(std::move(value));
    return promise.get_future();
  }
  static std::future<void> ready() {
    std::promise<void> promise;
    promise.set_value();
    return promise.get_future();
  }
  render::DeviceSummary device_;
};

}  // namespace

TEST_CASE("video channels: one encoder for its viewers; a late or slow viewer skips to a key frame") {
  PictureQueue queue;
  service::FrameStatsBook stats;
  service::Metrics metrics;
  service::SharedFrames shared;
  const service::SessionFrameContext context{queue, stats, metrics, &shared};
  auto session = std::make_shared<service::Session>("s-0000000000000001", "token");
  FrameRequest request = service::parseStreamQuery(
      {{"codec", "vp9"}, {"width", "64"}, {"height", "48"}, {"fps", "10"}, {"bitrate", "300"}},
      4096);
  encode::VideoSettings settings;
  settings.codec = encode::VideoCodec::Vp9;
  settings.width = 64;
  settings.height = 48;
  settings.fps = 10;
  settings.bitrateKbps = 300;
  settings.threads = 1;
  const auto interval = std::chrono::milliseconds(100);
  const size_t backlog = service::SharedFrames::maxVideoBacklog(10);
  REQUIRE(backlog == 10);  // max(8, fps)
  const auto edit = [&] {
    std::lock_guard lock(session->mutex);
    ++session->version;
  };
  // A viewer's client: decodes every chunk it gets, in order.
  struct Client {
    service::SharedFrames::VideoViewer viewer;
    encode::VideoDecoder decoder{encode::VideoCodec::Vp9};
    std::vector<service::SharedFrames::VideoFramePtr> got;
    std::vector<service::SharedFrames::VideoFramePtr> take(
        const service::SessionFrameContext& c, const service::SessionPtr& s,
        const FrameRequest& r, std::chrono::milliseconds maxAge,
        service::SharedFrames& frames) {
      auto chunks = frames.nextVideo(c, s, r, viewer, maxAge);
      for (const auto& chunk : chunks) {
        encode::VideoDecoder::Picture picture = decoder.decode(
            {reinterpret_cast<const uint8_t*>(chunk->payload.data()), chunk->payload.size()});
        CHECK(picture.width == 64);
        got.push_back(chunk);
      }
      return chunks;
    }
  };
  Client a{shared.joinVideo(session, request, settings)};
  Client b{shared.joinVideo(session, request, settings)};
  CHECK(a.viewer.channel == b.viewer.channel);
  CHECK(shared.videoChannelCount() == 1);
  // Another bitrate is another encoder.
  {
    encode::VideoSettings other = settings;
    other.bitrateKbps = 600;
    FrameRequest otherRequest = request;
    otherRequest.video->bitrateKbps = 600;
    auto third = shared.joinVideo(session, otherRequest, other);
    CHECK(third.channel != a.viewer.channel);
    CHECK(shared.videoChannelCount() == 2);
  }
  CHECK(shared.videoChannelCount() == 1);  // gone with its only viewer

  // The first frame: rendered once, a key frame, for both.
  auto first = a.take(context, session, request, interval, shared);
  REQUIRE(first.size() == 1);
  CHECK(first[0]->key);
  auto firstB = b.take(context, session, request, interval, shared);
  REQUIRE(firstB.size() == 1);
  CHECK(firstB[0] == first[0]);  // the same chunk, not an encode of its own
  CHECK(queue.rendered == 1);
  CHECK(shared.videoEncodeCount() == 1);

  // Three edits that only `a` asks for: `b` then gets the three deltas at once, in order.
  for (int i = 0; i < 3; ++i) {
    edit();
    REQUIRE(a.take(context, session, request, interval, shared).size() == 1);
  }
  auto caught = b.take(context, session, request, interval, shared);
  REQUIRE(caught.size() == 3);
  CHECK_FALSE(caught[0]->key);
  CHECK(caught.back() == a.got.back());
  CHECK(queue.rendered == 4);
  CHECK(b.viewer.resyncs == 0);

  // `b` stalls for more than its backlog: it skips to a key frame (forced on its next take: one
  // render), decodes from there, and `a` takes that key frame in order with what follows.
  for (size_t i = 0; i < backlog + 3; ++i) {
    edit();
    REQUIRE(a.take(context, session, request, interval, shared).size() == 1);
  }
  const uint32_t renderedBefore = queue.rendered;
  auto resynced = b.take(context, session, request, interval, shared);
  REQUIRE(resynced.size() == 1);
  CHECK(resynced[0]->key);
  CHECK(b.viewer.resyncs == 1);
  CHECK(shared.videoResyncCount() == 1);
  // It lowered the channel's bitrate a step (3/4) for the frame it made.
  CHECK(b.viewer.channel->encoder.settings().bitrateKbps == 225);
  CHECK(queue.rendered == renderedBefore + 1);
  edit();
  auto next = a.take(context, session, request, interval, shared);
  REQUIRE(next.size() == 2);  // the key frame b asked for, then the new frame
  CHECK(next[0] == resynced[0]);
  CHECK(queue.rendered == renderedBefore + 2);

  // A viewer joining now gets the log from its key frame (2 chunks: short enough), no render.
  Client c{shared.joinVideo(session, request, settings)};
  auto joined = c.take(context, session, request, interval, shared);
  REQUIRE(joined.size() == 2);
  CHECK(joined[0]->key);
  CHECK(queue.rendered == renderedBefore + 2);
  // After more than 4 chunks since the key frame, a joiner's key frame is forced (one render).
  for (int i = 0; i < 4; ++i) {
    edit();
    REQUIRE(a.take(context, session, request, interval, shared).size() == 1);
  }
  Client d{shared.joinVideo(session, request, settings)};
  auto late = d.take(context, session, request, interval, shared);
  REQUIRE(late.size() == 1);
  CHECK(late[0]->key);
  CHECK(late[0]->version == a.got.back()->version);  // the same state, encoded as a key frame
  CHECK(shared.videoResyncCount() == 1);  // joiners are not slow viewers
  // Falling behind again within a second: counted, but no second step down yet.
  REQUIRE(a.take(context, session, request, interval, shared).size() == 1);  // d's key frame
  for (size_t i = 0; i < backlog + 3; ++i) {
    edit();
    REQUIRE(a.take(context, session, request, interval, shared).size() == 1);
  }
  REQUIRE(b.take(context, session, request, interval, shared).front()->key);
  CHECK(b.viewer.resyncs == 2);
  CHECK(b.viewer.channel->encoder.settings().bitrateKbps == 225);
}

TEST_CASE("video channels: the bitrate steps down for a slow viewer and back up when none is") {
  PictureQueue queue;
  service::FrameStatsBook stats;
  service::Metrics metrics;
  // Up a step after 500 ms without one (not 10 s), down at most every 100 ms (not 1 s).
  service::SharedFrames shared(std::chrono::milliseconds(500), std::chrono::milliseconds(100));
  const service::SessionFrameContext context{queue, stats, metrics, &shared};
  auto session = std::make_shared<service::Session>("s-0000000000000002", "token");
  FrameRequest request = service::parseStreamQuery(
      {{"codec", "vp8"}, {"width", "64"}, {"height", "48"}, {"fps", "8"}, {"bitrate", "1000"}},
      4096);
  encode::VideoSettings settings{encode::VideoCodec::Vp8, 64, 48, 8, 1000, 1};
  const auto maxAge = std::chrono::milliseconds(125);
  auto fast = shared.joinVideo(session, request, settings);
  auto slow = shared.joinVideo(session, request, settings);
  const auto bitrate = [&] { return fast.channel->encoder.settings().bitrateKbps; };
  const auto edit = [&] {
    std::lock_guard lock(session->mutex);
    ++session->version;
  };
  REQUIRE(shared.nextVideo(context, session, request, fast, maxAge).size() == 1);
  REQUIRE(shared.nextVideo(context, session, request, slow, maxAge).size() == 1);
  // `slow` falls 9 frames behind (more than max(8, fps)) five times, 150 ms apart: 1000 -> 750 ->
  // 562 -> 421 -> 315 -> 250 (the floor: a quarter of the asked 1000).
  std::vector<uint32_t> steps;
  for (int round = 0; round < 5; ++round) {
    for (int i = 0; i < 9; ++i) {
      edit();
      REQUIRE(shared.nextVideo(context, session, request, fast, maxAge).size() == 1);
    }
    REQUIRE(shared.nextVideo(context, session, request, slow, maxAge).front()->key);
    steps.push_back(bitrate());
    REQUIRE(shared.nextVideo(context, session, request, fast, maxAge).front()->key);  // caught up
    std::this_thread::sleep_for(std::chrono::milliseconds(round < 4 ? 150 : 0));
  }
  INFO("steps down: ", doctest::toString(steps.size()), " ", steps[0], " ", steps[1], " ", steps[2],
       " ", steps[3], " ", steps[4]);
  CHECK(steps == std::vector<uint32_t>{750, 562, 421, 315, 250});
  // No viewer behind: one step up (5/4) per 500 ms, back to the asked bitrate and no further.
  std::vector<uint32_t> up;
  for (int i = 0; i < 8; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(520));
    edit();
    REQUIRE(shared.nextVideo(context, session, request, fast, maxAge).size() == 1);
    REQUIRE(shared.nextVideo(context, session, request, slow, maxAge).size() == 1);
    up.push_back(bitrate());
  }
  CHECK(up == std::vector<uint32_t>{313, 392, 491, 614, 768, 961, 1000, 1000});
  CHECK(shared.videoEncodeCount() == queue.rendered);
  CHECK(shared.videoChannelCount() == 1);
}
