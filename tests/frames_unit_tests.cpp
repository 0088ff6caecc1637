// CPU-only tests of the frame routes' pieces: session frame and stream queries, the metrics
// exposition, and the multipart framing of streams.
#include <doctest/doctest.h>

#include <map>
#include <string>

#include "service/frame_query.h"
#include "service/metrics.h"
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
      {{{"eye", "1,2,3"}}, "eye", true},
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
  CHECK(service::parseStreamQuery({{"format", "png"}, {"fps", "60"}}, 2048).fps == 60);
  CHECK(service::parseStreamQuery({{"fps", "1"}}, 2048).fps == 1);
  CHECK(failureOf([] { service::parseStreamQuery({{"format", "raw"}}, 2048); }).parameter ==
        "format");
  CHECK(failureOf([] { service::parseStreamQuery({{"fps", "0"}}, 2048); }).parameter == "fps");
  CHECK(failureOf([] { service::parseStreamQuery({{"fps", "61"}}, 2048); }).parameter == "fps");
  Failure time = failureOf([] { service::parseStreamQuery({{"time", "1"}}, 2048); });
  CHECK(time.parameter == "time");
  CHECK(time.unknown);
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
