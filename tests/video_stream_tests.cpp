// GET .../stream?codec=: video streams over loopback against the real myriad-server (validation
// on). The chunks are read as a client would (tests/browser reads the same ones with WebCodecs) and
// decoded with libvpx: the first is a key frame, pictures match the PNG frame of the same state,
// edits arrive as delta frames that change pixels, idle streams send keep-alives, and a closed
// stream stops encoding; a viewer that reads too slowly skips to a key frame without stalling another
// viewer of the same encoder.
#include <doctest/doctest.h>
#include <httplib.h>

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <tuple>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "encode/png.h"
#include "encode/video.h"
#include "server_process.h"

using myriad::encode::psnrRgb;
using myriad::encode::VideoCodec;
using myriad::encode::VideoDecoder;
using myriad::test::ApiClient;
using myriad::test::createSession;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using myriad::test::VideoReader;
using Chunk = myriad::test::VideoChunk;
using myriad::test::bearer;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr uint32_t kWidth = 96;
constexpr uint32_t kHeight = 64;

std::span<const uint8_t> bytesOf(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// The session's PNG frame, as RGBA; with `time`, at that animation time (the state a chunk of an
// animated session says it shows; a time also animates a session that is not animated).
std::vector<uint8_t> pngFrame(ApiClient& api, const TestSession& session,
                              std::optional<double> time = std::nullopt) {
  std::string query = "/frame?format=png&width=" + std::to_string(kWidth) +
                      "&height=" + std::to_string(kHeight);
  if (time) {
    char timeText[64];
    std::snprintf(timeText, sizeof timeText, "%.17g", *time);
    query += std::string("&time=") + timeText;
  }
  myriad::test::Reply reply = api.get(session.path() + query, session.token);
  REQUIRE(reply.status == 200);
  myriad::encode::DecodedImage png = myriad::encode::decodePng(bytesOf(reply.body));
  REQUIRE(png.width == kWidth);
  return png.rgba;
}

std::string videoPath(const TestSession& session, const std::string& query) {
  return session.path() + "/stream?width=" + std::to_string(kWidth) +
         "&height=" + std::to_string(kHeight) + "&" + query;
}

}  // namespace

TEST_CASE("video streams: key frame first, PNG-close pictures, edits as deltas, keep-alives") {
  ServerProcess server({"--lights", "64"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession session = createSession(api);

  for (auto [name, codec, webName] : {std::tuple{"vp8", VideoCodec::Vp8, "vp8"},
                                      std::tuple{"vp9", VideoCodec::Vp9, "vp09.00.10.08"}}) {
    const std::string codecName = name;
    CAPTURE(codecName);
    VideoReader reader(server, videoPath(session, std::string("codec=") + name + "&fps=8&bitrate=600"),
                       bearer(session.token));
    REQUIRE(reader.status() == 200);
    CHECK(reader.header("Content-Type") == "application/x-myriad-video");
    CHECK(reader.header("X-Myriad-Codec") == webName);
    std::vector<Chunk> chunks = reader.waitFor(1, std::chrono::seconds(120));
    REQUIRE(chunks.size() == 1);
    const Chunk first = chunks[0];
    CHECK(first.kind == 1);  // a key frame
    CHECK(first.width == kWidth);
    CHECK(first.height == kHeight);
    CHECK(first.sequence == 1);
    CHECK(first.payload.size() > 20);
    VideoDecoder decoder(codec);
    VideoDecoder::Picture before = decoder.decode(bytesOf(first.payload));
    REQUIRE(before.width == kWidth);
    REQUIRE(before.height == kHeight);
    const double psnrFirst = psnrRgb(before.rgba, pngFrame(api, session));
    MESSAGE(codecName, " key frame: ", first.payload.size(), " bytes, ", psnrFirst,
            " dB against the PNG frame, encoded in ", first.encodeUs, " us");
    CHECK(psnrFirst > 30.0);

    // Idle: a keep-alive after about 2 s, without a picture, repeating the sequence number.
    chunks = reader.waitFor(2, std::chrono::seconds(30));
    REQUIRE(chunks.size() == 2);
    CHECK(chunks[1].kind == 3);
    CHECK(chunks[1].payload.empty());
    CHECK(chunks[1].sequence == 1);
    const double gap = std::chrono::duration<double>(chunks[1].arrived - first.arrived).count();
    CHECK(gap > 1.5);
    CHECK(gap < 3.5);

    // An edit: a delta frame of a newer version whose pixels changed, matching the new PNG.
    const double fov = std::string(name) == "vp8" ? 30.0 : 70.0;
    REQUIRE(api.patch(session.path() + "/camera", json{{"fovY", fov}}.dump(), session.token)
                .status == 200);
    chunks = reader.waitFor(3, std::chrono::seconds(60));
    REQUIRE(chunks.size() == 3);
    const Chunk& edited = chunks[2];
    CHECK(edited.kind == 2);
    CHECK(edited.sequence == 2);
    CHECK(edited.version > first.version);
    CHECK(edited.timestampUs > first.timestampUs);
    VideoDecoder::Picture after = decoder.decode(bytesOf(edited.payload));
    const double psnrEdited = psnrRgb(after.rgba, pngFrame(api, session));
    const double psnrChange = psnrRgb(after.rgba, before.rgba);
    MESSAGE(codecName, " delta frame: ", edited.payload.size(), " bytes, ", psnrEdited,
            " dB against its PNG, ", psnrChange, " dB against the frame before the edit");
    CHECK(psnrEdited > 30.0);
    CHECK(psnrChange < psnrEdited - 5.0);  // the picture really changed
    CHECK(reader.framingError() == "");
  }

  // Bad requests are problems naming the parameter.
  for (auto [query, parameter] : {std::pair{"codec=av1", "codec"},
                                  std::pair{"codec=h264&container=webm", "container"},
                                  std::pair{"codec=vp8&format=jpeg", "format"},
                                  std::pair{"codec=vp8&bitrate=10", "bitrate"}}) {
    myriad::test::Reply reply = api.get(videoPath(session, query), session.token);
    myriad::test::checkProblem(reply, 400, "invalid-parameter", query, std::nullopt, std::nullopt,
                               parameter);
  }
  CHECK(myriad::test::validationMessages(api) == 0);
  REQUIRE(server.stop().has_value());
}

TEST_CASE("video streams: a closed stream stops encoding; animated frames all arrive in order") {
  ServerProcess server({"--lights", "64"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession session = createSession(api);
  REQUIRE(api.patch(session.path() + "/settings", json{{"animate", true}}.dump(), session.token)
              .status == 200);
  const auto framesRendered = [&] {
    myriad::test::Reply reply = api.get(session.path() + "/stats", session.token);
    REQUIRE(reply.status == 200);
    return reply.json["frames"].get<uint64_t>();
  };
  {
    // A bitrate well above the default's 50 kbit/s floor: what is checked is that each frame is
    // the picture of its header's time, not how the rate control spends a starved budget on
    // moving lights (at the default, delta frames measured 29.3-30.3 dB on an idle lavapipe).
    VideoReader reader(server, videoPath(session, "codec=vp8&fps=4&bitrate=400"),
                       bearer(session.token));
    REQUIRE(reader.status() == 200);
    std::vector<Chunk> chunks = reader.waitFor(4, std::chrono::seconds(120));
    REQUIRE(chunks.size() >= 4);
    VideoDecoder decoder(VideoCodec::Vp8);
    for (size_t i = 0; i < chunks.size(); ++i) {
      CAPTURE(i);
      CHECK(chunks[i].kind == (i == 0 ? 1 : 2));
      CHECK(chunks[i].sequence == i + 1);
      if (i > 0) CHECK(chunks[i].time > chunks[i - 1].time);  // the lights moved on
      VideoDecoder::Picture picture = decoder.decode(bytesOf(chunks[i].payload));
      REQUIRE(picture.width == kWidth);
      // The animation time in the header renders the same picture as a PNG frame.
      const double psnr = psnrRgb(picture.rgba, pngFrame(api, session, chunks[i].time));
      MESSAGE("animated frame ", i + 1, " at t=", chunks[i].time, ": ", psnr, " dB against its PNG");
      CHECK(psnr > 30.0);
    }
  }  // the reader closes the connection
  const uint64_t atClose = framesRendered();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // 6 frames at 4 fps
  const uint64_t after = framesRendered();
  MESSAGE("frames rendered after the client closed its animated video stream: ", after - atClose);
  CHECK(after - atClose <= 1);
  myriad::test::Reply metrics = api.get("/metrics");
  CHECK(metrics.body.find("myriad_streams 0") != std::string::npos);
  REQUIRE(server.stop().has_value());
}

TEST_CASE("video streams: a viewer that reads too slowly skips to a key frame; the other never stalls") {
  ServerProcess server({"--lights", "64"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  TestSession session = createSession(api);
  REQUIRE(api.patch(session.path() + "/settings", json{{"animate", true}}.dump(), session.token)
              .status == 200);
  // 10 fps: a viewer more than max(8, fps) = 10 chunks behind skips to a key frame.
  const std::string path =
      session.path() + "/stream?codec=vp9&fps=10&width=320&height=240&bitrate=8000";
  const auto metric = [&](const std::string& name) {
    myriad::test::Reply metrics = api.get("/metrics");
    const size_t at = metrics.body.find("\n" + name + " ");
    REQUIRE(at != std::string::npos);
    return std::stoull(metrics.body.substr(at + name.size() + 2));
  };

  // The slow page: a small receive buffer and segment size (so the server's socket fills after a
  // few frames), and a body callback that reads a few kilobytes a second while `paused`: far
  // behind the stream, yet never stalled long enough (3 s without a byte taken) for the server to
  // give its connection up as a reader that stopped.
  std::mutex mutex;
  std::condition_variable resumed;
  bool paused = true;
  bool stop = false;
  std::string slowBytes;
  httplib::Client slowClient(server.host(), server.port());
  slowClient.set_read_timeout(300, 0);
  slowClient.set_socket_options([](int sock) {
    const int receiveBuffer = 4096, segment = 536;
    setsockopt(sock, SOL_SOCKET, SO_RCVBUF, &receiveBuffer, sizeof receiveBuffer);
    setsockopt(sock, IPPROTO_TCP, TCP_MAXSEG, &segment, sizeof segment);
  });
  std::thread slowThread([&] {
    slowClient.Get(path, bearer(session.token), [&](const char* data, size_t size) {
      std::unique_lock lock(mutex);
      slowBytes.append(data, size);
      resumed.wait_for(lock, std::chrono::milliseconds(300), [&] { return !paused || stop; });
      return !stop;
    });
  });
  VideoReader fast(server, path, bearer(session.token));
  REQUIRE(fast.status() == 200);
  fast.waitFor(2, std::chrono::seconds(120));
  // The slow page reads slowly while the fast one gets 100 chunks (at ~6 KB each, more than the
  // two sockets hold and the slow page's few kilobytes a second take), or for 24 s.
  const size_t before = fast.items().size();
  const auto pausedAt = Clock::now();
  fast.waitFor(before + 100, std::chrono::seconds(24));
  const size_t during = fast.items().size() - before;
  const double pausedFor = std::chrono::duration<double>(Clock::now() - pausedAt).count();
  const uint64_t resyncsBefore = metric("myriad_video_resyncs_total");
  {
    std::lock_guard lock(mutex);
    paused = false;
  }
  resumed.notify_all();
  // Reading again, it gets what was queued for it, then (too far behind) a key frame.
  const auto deadline = Clock::now() + std::chrono::seconds(120);
  std::vector<Chunk> slow;
  size_t keysAfterFirst = 0;
  while (Clock::now() < deadline && keysAfterFirst == 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    std::lock_guard lock(mutex);
    slow.clear();
    auto parse = myriad::test::videoChunkParser();
    std::string_view rest = slowBytes;
    while (size_t used = parse(rest, slow)) rest.remove_prefix(used);
    keysAfterFirst = std::count_if(slow.begin() + std::min<size_t>(1, slow.size()), slow.end(),
                                   [](const Chunk& c) { return c.kind == 1; });
  }
  {
    std::lock_guard lock(mutex);
    stop = true;
  }
  resumed.notify_all();
  slowClient.stop();
  slowThread.join();
  const uint64_t resyncs = metric("myriad_video_resyncs_total");
  MESSAGE("while the slow page read slowly for ", pausedFor, " s the other got ", during,
          " chunks; the slow page then got ", slow.size(), " chunks with ", keysAfterFirst,
          " key frame(s) after its first (", slowBytes.size(), " bytes); resyncs ", resyncsBefore,
          " -> ", resyncs);
  CHECK(during >= 12);  // not stalled
  CHECK(keysAfterFirst >= 1);
  CHECK(resyncs >= 1);
  // Everything either page got decodes in order with one decoder each: the slow page's skipped
  // deltas are never needed after its key frame.
  for (const std::vector<Chunk>& chunks : {fast.items(), slow}) {
    VideoDecoder decoder(VideoCodec::Vp9);
    size_t pictures = 0;
    for (const Chunk& c : chunks) {
      if (c.kind == 3) continue;
      CHECK_NOTHROW(decoder.decode(bytesOf(c.payload)));
      ++pictures;
    }
    CHECK(pictures >= 2);
  }
  CHECK(myriad::test::validationMessages(api) == 0);
  REQUIRE(server.stop().has_value());
}
