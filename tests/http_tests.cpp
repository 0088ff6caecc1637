// The real myriad-server over loopback: every route, every target, every kind of bad request,
// concurrency, back-pressure and shutdown. Each server runs with validation layers on and must
// end with zero validation messages.
#include <doctest/doctest.h>
#include <httplib.h>
#include <arpa/inet.h>
#include <poll.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <map>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/png.h"
#include "image_compare.h"
#include "server_process.h"
#include "server_timing.h"

using myriad::test::ExitStatus;
using myriad::test::ServerProcess;
using nlohmann::json;

namespace {

// Frames on lavapipe with validation take seconds at large sizes.
constexpr time_t kFrameTimeoutSeconds = 300;

std::unique_ptr<httplib::Client> clientFor(const ServerProcess& server) {
  auto client = std::make_unique<httplib::Client>(server.host(), server.port());
  client->set_read_timeout(kFrameTimeoutSeconds, 0);
  client->set_connection_timeout(10, 0);
  return client;
}

std::span<const uint8_t> bytesOf(const std::string& body) {
  return {reinterpret_cast<const uint8_t*>(body.data()), body.size()};
}

myriad::encode::DecodedImage getFrame(httplib::Client& client, const httplib::Params& params,
                                      std::string* serverTiming = nullptr) {
  httplib::Result res = client.Get("/v1/frame", params, httplib::Headers{});
  REQUIRE(res);
  INFO("body: ", res->body.substr(0, 400));
  REQUIRE(res->status == 200);
  CHECK(res->get_header_value("Content-Type") == "image/png");
  if (serverTiming != nullptr) *serverTiming = res->get_header_value("Server-Timing");
  return myriad::encode::decodePng(bytesOf(res->body));
}

// Standard deviation of luma over the image, 0..255: 0 for a uniform picture.
double lumaSpread(const myriad::encode::DecodedImage& image) {
  double sum = 0.0, sumSquares = 0.0;
  const size_t n = size_t(image.width) * image.height;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* p = &image.rgba[i * 4];
    double y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    sum += y;
    sumSquares += y * y;
  }
  double mean = sum / double(n);
  return std::sqrt(std::max(0.0, sumSquares / double(n) - mean * mean));
}

size_t distinctColours(const myriad::encode::DecodedImage& image) {
  std::set<uint32_t> colours;
  for (size_t i = 0; i + 3 < image.rgba.size(); i += 4) {
    colours.insert(uint32_t(image.rgba[i]) | uint32_t(image.rgba[i + 1]) << 8 |
                   uint32_t(image.rgba[i + 2]) << 16);
  }
  return colours.size();
}

// Fraction of pixels whose RGB differs by more than a rounding step.
double fractionDifferent(const myriad::encode::DecodedImage& a,
                         const myriad::encode::DecodedImage& b) {
  return myriad::test::fractionDifferent(a.rgba, b.rgba, 2);
}

// "gbuffer;dur=1.234, sun;dur=0.5" -> {gbuffer: 1.234, sun: 0.5}; a malformed entry fails.
std::map<std::string, double> parseServerTiming(const std::string& header) {
  std::map<std::string, double> metrics;
  for (const std::string& entry : myriad::test::serverTimingEntries(header)) {
    INFO("Server-Timing entry: ", entry);
    if (entry.starts_with("culling;desc=\"")) {  // the light lists' report, no duration
      CHECK(entry.find("dropped 0 light references") != std::string::npos);
      CHECK(entry.back() == '"');
      continue;
    }
    size_t semicolon = entry.find(";dur=");
    REQUIRE(semicolon != std::string::npos);
    std::string number = entry.substr(semicolon + 5);
    char* parsedEnd = nullptr;
    double value = std::strtod(number.c_str(), &parsedEnd);
    CHECK(parsedEnd == number.c_str() + number.size());
    CHECK(std::isfinite(value));
    CHECK(value >= 0.0);
    metrics[entry.substr(0, semicolon)] = value;
  }
  return metrics;
}

void checkProblem(const httplib::Result& res, int status, const std::string& parameter,
                  const std::string& what) {
  INFO("request: ", what);
  REQUIRE(res);
  INFO("body: ", res->body.substr(0, 400));
  CHECK(res->status == status);
  CHECK(res->get_header_value("Content-Type") == "application/problem+json");
  json body = json::parse(res->body, nullptr, false);
  REQUIRE_FALSE(body.is_discarded());
  CHECK(body["status"] == status);
  CHECK(body["type"].get<std::string>().starts_with("https://myriad.dev/problems/"));
  CHECK_FALSE(body["title"].get<std::string>().empty());
  std::string detail = body["detail"].get<std::string>();
  CHECK_FALSE(detail.empty());
  if (!parameter.empty()) {
    CHECK(body["parameter"] == parameter);
    CHECK(detail.find(parameter) != std::string::npos);
  }
}

json getInfo(httplib::Client& client) {
  httplib::Result res = client.Get("/v1/info");
  REQUIRE(res);
  REQUIRE(res->status == 200);
  CHECK(res->get_header_value("Content-Type") == "application/json");
  return json::parse(res->body);
}

void requireListening(const ServerProcess& server) {
  INFO("server stderr:\n", server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

void requireCleanStop(ServerProcess& server) {
  std::optional<ExitStatus> status = server.stop(std::chrono::seconds(60));
  INFO("server stderr:\n", server.stderrText());
  REQUIRE(status.has_value());
  CHECK(status->describe() == "exit 0");
  CHECK(server.stderrText().find("shutting down") != std::string::npos);
}

}  // namespace

TEST_CASE("http: the whole API against one server") {
  ServerProcess server({"--lights", "64", "--max-resolution", "1024"});
  requireListening(server);
  auto client = clientFor(server);

  // Health and info.
  {
    httplib::Result res = client->Get("/v1/health");
    REQUIRE(res);
    CHECK(res->status == 200);
    CHECK(json::parse(res->body) == json{{"status", "ok"}});
  }
  const json info = getInfo(*client);
  CHECK(info["server"]["name"] == "myriad-server");
  CHECK(info["server"]["version"] == MYRIAD_TEST_VERSION);
  for (const char* field :
       {"name", "type", "driverName", "driverInfo", "apiVersion", "vendorId", "deviceId", "index",
        "isCpu", "maxImageDimension2D", "maxStorageBufferRange", "maxComputeSharedMemorySize",
        "subgroupSize", "timestampPeriodNs", "timestampsSupported"}) {
    CHECK_MESSAGE(info["device"].contains(field), field);
  }
  CHECK_FALSE(info["device"]["name"].get<std::string>().empty());
  const int maxResolution = info["limits"]["maxResolution"];
  CHECK(maxResolution <= 1024);
  CHECK(maxResolution <= info["device"]["maxImageDimension2D"].get<int>());
  CHECK(info["validation"]["enabled"] == true);
  CHECK(info["scene"]["lights"] == 64);
  CHECK(info["scene"]["instances"].get<int>() > 0);
  CHECK(info["scene"]["materials"].get<int>() > 0);
  const std::vector<std::string> targets = info["targets"];
  REQUIRE_FALSE(targets.empty());
  CHECK(targets.front() == "final");
  for (const char* expected : {"albedo", "normal", "depth"}) {
    CHECK(std::find(targets.begin(), targets.end(), expected) != targets.end());
  }

  // Frames of several sizes come back at exactly that size.
  for (auto [w, h] : {std::pair<int, int>{160, 120}, {1, 1}, {333, 77}, {64, 480}, {1024, 8}}) {
    INFO("size ", w, "x", h);
    auto image = getFrame(*client, {{"width", std::to_string(w)}, {"height", std::to_string(h)}});
    CHECK(image.width == uint32_t(w));
    CHECK(image.height == uint32_t(h));
  }
  {
    // No parameters at all: the default size.
    auto image = getFrame(*client, {});
    CHECK(image.width == 1024);  // 1280 capped by --max-resolution
    CHECK(image.height == 576);
  }

  // Every target renders; the final image shows lit objects, not a flat clear colour.
  const httplib::Params small = {{"width", "160"}, {"height", "120"}};
  for (const std::string& target : targets) {
    INFO("target ", target);
    httplib::Params params = small;
    params.emplace("target", target);
    auto image = getFrame(*client, params);
    CHECK(image.width == 160);
    CHECK(image.height == 120);
    if (target == "final") {
      CHECK(lumaSpread(image) > 8.0);
      CHECK(distinctColours(image) > 200);
    }
    if (target == "normal" || target == "depth" || target == "position") {
      CHECK(distinctColours(image) > 8);
    }
    if (target == "albedo") CHECK(distinctColours(image) >= 3);  // floor, spheres, sky at least
  }

  // Server-Timing: every GPU pass, then the CPU encode, each with a number.
  {
    std::string header;
    getFrame(*client, small, &header);
    INFO("Server-Timing: ", header);
    std::map<std::string, double> metrics = parseServerTiming(header);
    CHECK(metrics.count("encode") == 1);
    CHECK(metrics.count("gbuffer") == 1);
    CHECK(metrics.size() >= 3);
    // final is anti-aliased by default: its own pass after the final pass; antialias=none and
    // data views have none.
    CHECK(metrics.count("final") == 1);  // names-once: the pass, not the target
    CHECK(metrics.count("antialias") == 1);
    httplib::Params plain = small;
    plain.emplace("antialias", "none");
    getFrame(*client, plain, &header);
    CHECK(parseServerTiming(header).count("antialias") == 0);
    httplib::Params normals = small;
    normals.emplace("target", "normal");  // names-once: a data view, the target's name
    getFrame(*client, normals, &header);
    CHECK(parseServerTiming(header).count("antialias") == 0);
  }

  // The camera parameters change the picture.
  {
    auto base = getFrame(*client, small);
    httplib::Params moved = small;
    moved.emplace("eye", "-8,6,-8");
    moved.emplace("look_at", "0,0.5,0");
    auto image = getFrame(*client, moved);
    CHECK(fractionDifferent(base, image) > 0.2);
    httplib::Params narrow = small;
    narrow.emplace("fov", "20");
    CHECK(fractionDifferent(base, getFrame(*client, narrow)) > 0.2);
    httplib::Params dark = small;
    dark.emplace("exposure", "0.1");
    CHECK(lumaSpread(getFrame(*client, dark)) < lumaSpread(base));
    httplib::Params down = small;  // straight down the default up axis
    down.emplace("eye", "0,15,0");
    down.emplace("look_at", "0,0,0");
    CHECK(lumaSpread(getFrame(*client, down)) > 2.0);
    // Same request, same picture.
    CHECK(fractionDifferent(base, getFrame(*client, small)) == 0.0);
    // Every technique shades the same picture (tests/technique_tests.cpp holds them to 1/255
    // in-process; here, through HTTP, the bar is that no pixel moves by more than 2/255).
    // Without anti-aliasing: at an edge, a 1/255 difference can tip a pixel over the filter's
    // contrast threshold and blend it (antialias_tests.cpp holds the filter to its own bars).
    httplib::Params unfiltered = small;
    unfiltered.emplace("antialias", "none");
    const auto plain = getFrame(*client, unfiltered);
    for (std::string_view technique : {"volumes", "tiled", "clustered"}) {
      httplib::Params with = unfiltered;
      with.emplace("technique", std::string(technique));
      auto shaded = getFrame(*client, with);
      REQUIRE(shaded.rgba.size() == plain.rgba.size());
      int worst = 0;
      for (size_t i = 0; i < plain.rgba.size(); ++i) {
        worst = std::max(worst, std::abs(int(plain.rgba[i]) - int(shaded.rgba[i])));
      }
      INFO("technique ", technique);
      CHECK(worst <= 2);
    }
  }

  // Every bad request is a problem naming its parameter, and the server carries on.
  const std::string tooBig = std::to_string(maxResolution + 1);
  const std::vector<std::pair<std::string, std::string>> badQueries = {
      {"target=bogus", "target"},
      {"target=", "target"},
      {"width=", "width"},
      {"width=abc", "width"},
      {"width=nan", "width"},
      {"width=inf", "width"},
      {"width=-5", "width"},
      {"width=0", "width"},
      {"width=12.5", "width"},
      {"width=" + tooBig, "width"},
      {"height=", "height"},
      {"height=NaN", "height"},
      {"height=0", "height"},
      {"height=-1", "height"},
      {"height=7.5", "height"},
      {"height=" + tooBig, "height"},
      {"eye=1,2", "eye"},
      {"eye=1,2,3,4", "eye"},
      {"eye=a,b,c", "eye"},
      {"eye=1,nan,3", "eye"},
      {"eye=", "eye"},
      {"look_at=0,0", "look_at"},
      {"look_at=x,0,0", "look_at"},
      {"look_at=0,inf,0", "look_at"},
      {"eye=1,1,1&look_at=1,1,1", "look_at"},
      {"fov=0", "fov"},
      {"fov=180", "fov"},
      {"fov=abc", "fov"},
      {"markers=maybe", "markers"},
      {"antialias=smaa", "antialias"},
      {"antialias=", "antialias"},
      {"exposure=-1", "exposure"},
      {"exposure=nan", "exposure"},
      {"technique=forward", "technique"},
      {"colour=red", "colour"},
      {"width=64&width=65", "width"},
  };
  for (const auto& [query, parameter] : badQueries) {
    checkProblem(client->Get("/v1/frame?" + query), 400, parameter, query);
  }
  checkProblem(client->Get("/v1/nope"), 404, "", "GET /v1/nope");
  // "/" is the web client (api_frames_tests.cpp); a path beside it is not.
  checkProblem(client->Get("/index.htm"), 404, "", "GET /index.htm");
  checkProblem(client->Get("/v1/frame/extra"), 404, "", "GET /v1/frame/extra");
  for (const char* path : {"/v1/frame", "/v1/health", "/v1/info"}) {
    httplib::Result post = client->Post(path, "{}", "application/json");
    checkProblem(post, 405, "", std::string("POST ") + path);
    if (post) CHECK(post->get_header_value("Allow") == "GET, HEAD, OPTIONS");
    checkProblem(client->Delete(path), 405, "", std::string("DELETE ") + path);
    checkProblem(client->Put(path, "x", "text/plain"), 405, "", std::string("PUT ") + path);
  }
  {
    // HEAD is allowed (no body), as the Allow header says.
    httplib::Result head = client->Head("/v1/health");
    REQUIRE(head);
    CHECK(head->status == 200);
  }

  // Several clients at once: each gets its own frame at its own size.
  {
    std::vector<std::future<std::pair<int, std::pair<uint32_t, uint32_t>>>> results;
    for (int i = 0; i < 4; ++i) {
      results.push_back(std::async(std::launch::async, [&server, i] {
        auto c = clientFor(server);
        int w = 96 + 16 * i, h = 64 + 8 * i;
        httplib::Result res =
            c->Get("/v1/frame?width=" + std::to_string(w) + "&height=" + std::to_string(h));
        if (!res) return std::make_pair(-1, std::make_pair(0u, 0u));
        if (res->status != 200) return std::make_pair(res->status, std::make_pair(0u, 0u));
        auto image = myriad::encode::decodePng(bytesOf(res->body));
        return std::make_pair(200, std::make_pair(image.width, image.height));
      }));
    }
    for (int i = 0; i < 4; ++i) {
      auto [status, size] = results[i].get();
      CHECK(status == 200);
      CHECK(size.first == uint32_t(96 + 16 * i));
      CHECK(size.second == uint32_t(64 + 8 * i));
    }
  }

  // Still healthy, and the validation layers saw nothing wrong in all of it.
  {
    httplib::Result res = client->Get("/v1/health");
    REQUIRE(res);
    CHECK(res->status == 200);
  }
  const json after = getInfo(*client);
  CHECK(after["validation"]["messages"] == 0);
  requireCleanStop(server);
}

TEST_CASE("http: a full render queue answers 503 with Retry-After, then recovers") {
  ServerProcess server({"--lights", "64", "--max-queued-frames", "0", "--threads", "8"});
  requireListening(server);

  // With no waiting allowed, of several large frames asked for at once only those that find the
  // renderer idle are rendered.
  std::vector<std::future<httplib::Result>> results;
  for (int i = 0; i < 4; ++i) {
    results.push_back(std::async(std::launch::async, [&server] {
      return clientFor(server)->Get("/v1/frame?width=1024&height=1024");
    }));
  }
  int ok = 0, busy = 0;
  for (auto& result : results) {
    httplib::Result res = result.get();
    REQUIRE(res);
    if (res->status == 200) {
      ++ok;
    } else {
      checkProblem(res, 503, "", "concurrent frame");
      CHECK(res->get_header_value("Retry-After") == "1");
      ++busy;
    }
  }
  CHECK(ok >= 1);
  CHECK(busy >= 1);

  auto client = clientFor(server);
  auto image = getFrame(*client, {{"width", "32"}, {"height", "32"}});
  CHECK(image.width == 32);
  CHECK(getInfo(*client)["validation"]["messages"] == 0);
  requireCleanStop(server);
}

TEST_CASE("http: --gbuffer compute makes the G-buffer in compute, named in Server-Timing") {
  ServerProcess server({"--lights", "64", "--gbuffer", "compute"});
  requireListening(server);
  auto client = clientFor(server);
  std::string timing;
  auto image = getFrame(*client, {{"width", "96"}, {"height", "64"}}, &timing);
  INFO("Server-Timing: ", timing);
  const std::map<std::string, double> passes = parseServerTiming(timing);
  // The built-in scene's materials are opaque and untextured: the compute path on lavapipe too.
  CHECK(passes.count("visibility") == 1);
  CHECK(passes.count("resolve") == 1);
  CHECK(passes.count("gbuffer") == 0);
  CHECK(lumaSpread(image) > 5.0);
  CHECK(getInfo(*client)["validation"]["messages"] == 0);
  requireCleanStop(server);
}

TEST_CASE("http: SIGTERM during a frame finishes the frame, then exits 0") {
  // A grace far past the frames' time: this is about answering what is in flight.
  ServerProcess server({"--lights", "256", "--shutdown-grace", "300"});
  requireListening(server);

  // Two large frames: one rendering and one queued behind it when the signal arrives, so the
  // signal certainly lands while requests are in flight.
  std::atomic<bool> signalSent{false};
  auto request = [&server, &signalSent](int width) {
    httplib::Result res =
        clientFor(server)->Get("/v1/frame?width=" + std::to_string(width) + "&height=2048");
    bool afterSignal = signalSent.load();
    return std::make_pair(std::move(res), afterSignal);
  };
  // Sized to take over a second each on lavapipe (1536x1024 had become quicker than the 400 ms
  // before the signal: 0.3 s on the 2-core machine).
  auto first = std::async(std::launch::async, request, 4096);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto second = std::async(std::launch::async, request, 3840);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  server.signal(SIGTERM);
  signalSent = true;

  for (auto* pending : {&first, &second}) {
    auto [res, afterSignal] = pending->get();
    REQUIRE(res);
    CHECK(res->status == 200);
    CHECK(afterSignal);  // else the frame was too quick to test anything
    auto image = myriad::encode::decodePng(bytesOf(res->body));
    CHECK(image.height == 2048);
  }
  std::optional<ExitStatus> status = server.waitForExit(std::chrono::seconds(60));
  INFO("server stderr:\n", server.stderrText());
  REQUIRE(status.has_value());
  CHECK(status->describe() == "exit 0");
  CHECK(server.stderrText().find("shutting down") != std::string::npos);
}

TEST_CASE("http: SIGINT on an idle server exits 0") {
  ServerProcess server({"--lights", "8"});
  requireListening(server);
  server.signal(SIGINT);
  std::optional<ExitStatus> status = server.waitForExit(std::chrono::seconds(30));
  INFO("server stderr:\n", server.stderrText());
  REQUIRE(status.has_value());
  CHECK(status->describe() == "exit 0");
}

TEST_CASE("start-up failures are one sentence and a non-zero exit") {
  struct Case {
    std::vector<std::string> args;
    int exitCode;
    std::string mention;
  };
  const std::vector<Case> cases = {
      {{"--help"}, 0, ""},
      {{"--bogus"}, 2, "--bogus"},
      {{"--lights", "many"}, 2, "--lights"},
      {{"--port", "70000"}, 2, "--port"},
      {{"--model", "/nonexistent/thing.glb"}, 1, "thing.glb"},
      {{"--device", "no-such-device-name"}, 1, "device"},
  };
  for (const Case& c : cases) {
    INFO("args: ", c.args.front());
    ServerProcess server(c.args, std::chrono::seconds(60));
    INFO("stderr: ", server.stderrText());
    REQUIRE(server.start() == ServerProcess::Start::Exited);
    std::optional<ExitStatus> status = server.waitForExit(std::chrono::seconds(1));
    REQUIRE(status.has_value());
    CHECK(status->describe() == "exit " + std::to_string(c.exitCode));
    std::string text = server.stderrText();
    CHECK(text.find(c.mention) != std::string::npos);
    CHECK(text.find("terminate called") == std::string::npos);
  }

  // The port taken by a running server: the second cannot bind, and says so.
  ServerProcess first({"--lights", "8"});
  requireListening(first);
  ServerProcess second(
      {"--lights", "8", "--host", "127.0.0.1", "--port", std::to_string(first.port())},
      std::chrono::seconds(60), /*appendTestArgs=*/false);
  INFO("stderr: ", second.stderrText());
  REQUIRE(second.start() == ServerProcess::Start::Exited);
  CHECK(second.waitForExit(std::chrono::seconds(1))->describe() == "exit 1");
  CHECK(second.stderrText().find(std::to_string(first.port())) != std::string::npos);
  requireCleanStop(first);
}

namespace {
int connectLoopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  REQUIRE(fd >= 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(uint16_t(port));
  ::inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
  REQUIRE(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
  return fd;
}
}  // namespace

TEST_CASE("http: a client that never finishes its request holds a shutdown no longer than --shutdown-grace") {
  ServerProcess server({"--lights", "8", "--shutdown-grace", "2"});
  requireListening(server);
  // Two slow clients, each on its own thread, a line or a byte a second: one whose head never
  // ends (slowloris: it never reaches a worker, so it holds nothing), one whose body never ends
  // (a worker reads it: the request is in flight, and the grace bounds the wait for it).
  const int slowHead = connectLoopback(server.port());
  const int slowBody = connectLoopback(server.port());
  REQUIRE(slowHead >= 0);
  REQUIRE(slowBody >= 0);
  std::atomic<bool> done{false};
  std::thread slow([&] {
    std::string line = "GET /v1/health HTTP/1.1\r\nHost: x\r\n";
    const std::string post =
        "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        "Content-Length: 1000\r\n\r\n{";
    ::send(slowBody, post.data(), post.size(), MSG_NOSIGNAL);
    for (int i = 0; !done && i < 120; ++i) {
      ::send(slowHead, line.data(), line.size(), MSG_NOSIGNAL);
      ::send(slowBody, " ", 1, MSG_NOSIGNAL);
      line = "X-Slow-" + std::to_string(i) + ": 1\r\n";
      std::this_thread::sleep_for(std::chrono::seconds(1));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const auto signalled = std::chrono::steady_clock::now();
  server.signal(SIGTERM);
  std::optional<ExitStatus> status = server.waitForExit(std::chrono::seconds(20));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  done = true;
  slow.join();
  ::close(slowHead);
  ::close(slowBody);
  INFO("server stderr:\n", server.stderrText());
  REQUIRE(status.has_value());
  CHECK(status->describe() == "exit 0");
  MESSAGE("exited ", seconds, " s after SIGTERM with a slow client connected (grace 2 s)");
  CHECK(seconds >= 1.5);  // it did wait for the open request
  CHECK(seconds <= 3.0);  // grace + 1 s
  CHECK(server.stderrText().find("after the 2 s shutdown grace") != std::string::npos);
}

TEST_CASE("http: three requests on one kept-alive connection take about as long as one") {
  ServerProcess server({"--lights", "8"});
  requireListening(server);
  httplib::Client client(server.host(), server.port());
  client.set_keep_alive(true);
  client.set_read_timeout(30, 0);
  // GET /v1/info answers with headers and a body (two writes on the server's side): with Nagle's
  // algorithm on, the body of every response after a connection's first waited for the client's
  // delayed ACK, 40 ms each.
  auto request = [&] {
    httplib::Result res = client.Get("/v1/info");
    REQUIRE(res);
    REQUIRE(res->status == 200);
    CHECK(res->body.size() > 100);
  };
  request();  // connect
  auto timeRequests = [&](int count) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < count; ++i) request();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
  };
  std::vector<double> one, three;
  for (int round = 0; round < 7; ++round) {
    one.push_back(timeRequests(1));
    three.push_back(timeRequests(3));
  }
  std::sort(one.begin(), one.end());
  std::sort(three.begin(), three.end());
  const double oneMs = one[one.size() / 2];
  const double threeMs = three[three.size() / 2];
  MESSAGE("one request on a kept-alive connection: ", oneMs, " ms (median of 7); three: ",
          threeMs, " ms");
  CHECK(threeMs - oneMs < 5.0);
}

namespace {

struct ChunkedUpload {
  uint64_t sentBytes = 0;    // body bytes the server took before it answered or closed
  std::string response;      // what came back
  uint64_t peakResident = 0; // the server's largest RSS seen while sending
};

// Sends `head` (request line and headers, ending in a blank line), then up to `bodyBytes` of
// chunked body in 1 MiB chunks of `fill`, sampling the server's RSS, until the server answers or
// closes the connection; then reads the answer.
ChunkedUpload sendChunked(const ServerProcess& server, const std::string& head, uint64_t bodyBytes,
                          char fill) {
  ChunkedUpload upload;
  const int fd = connectLoopback(server.port());
  REQUIRE(::send(fd, head.data(), head.size(), MSG_NOSIGNAL) == ssize_t(head.size()));
  const std::string chunk = "100000\r\n" + std::string(1u << 20, fill) + "\r\n";
  std::atomic<bool> sending{true};
  std::thread sampler([&] {
    while (sending) {
      upload.peakResident = std::max(upload.peakResident, server.residentBytes());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  timeval timeout{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  while (upload.sentBytes < bodyBytes) {
    // Stop as soon as the server has answered.
    pollfd readable{fd, POLLIN, 0};
    if (::poll(&readable, 1, 0) > 0) break;
    const ssize_t n = ::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL);
    if (n <= 0) break;
    upload.sentBytes += uint64_t(n);
  }
  if (upload.sentBytes >= bodyBytes) ::send(fd, "0\r\n\r\n", 5, MSG_NOSIGNAL);
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    upload.response.append(buffer, size_t(n));
    if (upload.response.find("}") != std::string::npos) break;  // the JSON problem has ended
  }
  sending = false;
  sampler.join();
  ::close(fd);
  return upload;
}

}  // namespace

TEST_CASE("http: chunked bodies are counted as they arrive and cut at the route's limit") {
  ServerProcess server({"--lights", "8"});
  requireListening(server);
  const uint64_t residentBefore = server.residentBytes();
  REQUIRE(residentBefore > 0);

  SUBCASE("600 MB of chunked JSON to POST /v1/sessions (no token needed): 413 early") {
    ChunkedUpload upload = sendChunked(
        server,
        "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        "Transfer-Encoding: chunked\r\n\r\n",
        600ull << 20, ' ');
    INFO("response: ", upload.response.substr(0, 600));
    MESSAGE("server RSS ", residentBefore >> 20, " MiB before, at most ",
            upload.peakResident >> 20, " MiB while ", upload.sentBytes >> 20,
            " MiB of chunked body were sent");
    CHECK(upload.response.starts_with("HTTP/1.1 413"));
    CHECK(upload.response.find("maxBodyBytes") != std::string::npos);
    CHECK(upload.sentBytes < (64ull << 20));  // refused long before 600 MB
    CHECK(upload.peakResident <= residentBefore + (64ull << 20));
  }
  SUBCASE("600 MB of chunked multipart to PUT .../model: 413 naming maxUploadBytes") {
    httplib::Client client(server.host(), server.port());
    httplib::Result created = client.Post("/v1/sessions", "{}", "application/json");
    REQUIRE(created);
    REQUIRE(created->status == 201);
    const json session = json::parse(created->body);
    const std::string preamble =
        "--XyZ\r\nContent-Disposition: form-data; name=\"f\"; filename=\"big.obj\"\r\n"
        "Content-Type: application/octet-stream\r\n\r\n";
    char size[16];
    std::snprintf(size, sizeof size, "%zx\r\n", preamble.size());
    const std::string head =
        "PUT /v1/sessions/" + session.at("id").get<std::string>() +
        "/model HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
        session.at("token").get<std::string>() +
        "\r\nContent-Type: multipart/form-data; boundary=XyZ\r\nTransfer-Encoding: chunked\r\n\r\n" +
        size + preamble + "\r\n";
    ChunkedUpload upload = sendChunked(server, head, 600ull << 20, '#');
    INFO("response: ", upload.response.substr(0, 600));
    MESSAGE("server RSS ", residentBefore >> 20, " MiB before, at most ",
            upload.peakResident >> 20, " MiB while ", upload.sentBytes >> 20,
            " MiB of chunked multipart were sent");
    CHECK(upload.response.starts_with("HTTP/1.1 413"));
    CHECK(upload.response.find("maxUploadBytes") != std::string::npos);
    // Read up to the route's limit (64 MiB by default) and no further; a string grows by doubling.
    CHECK(upload.sentBytes < (96ull << 20));
    CHECK(upload.peakResident <= residentBefore + (160ull << 20));
  }
  SUBCASE("a chunked body within the limit is read and served") {
    const std::string body = "{ }";
    std::string request =
        "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        "Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n";
    char size[16];
    std::snprintf(size, sizeof size, "%zx\r\n", body.size());
    request += size + body + "\r\n0\r\n\r\n";
    const int fd = connectLoopback(server.port());
    REQUIRE(::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == ssize_t(request.size()));
    std::string response;
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, size_t(n));
    ::close(fd);
    INFO("response: ", response.substr(0, 600));
    CHECK(response.starts_with("HTTP/1.1 201"));
    CHECK(response.find("\"token\"") != std::string::npos);
  }
  httplib::Client client(server.host(), server.port());
  httplib::Result health = client.Get("/v1/health");
  REQUIRE(health);
  CHECK(health->status == 200);
  requireCleanStop(server);
}

TEST_CASE("http: GET /v1/ready is 200 while sessions can be created, 503 when full") {
  ServerProcess server({"--lights", "8", "--max-sessions", "1"});
  requireListening(server);
  httplib::Client client(server.host(), server.port());
  httplib::Result ready = client.Get("/v1/ready");
  REQUIRE(ready);
  CHECK(ready->status == 200);
  CHECK(ready->body == R"({"status":"ok"})");
  httplib::Result created = client.Post("/v1/sessions", "{}", "application/json");
  REQUIRE(created);
  REQUIRE(created->status == 201);
  httplib::Result full = client.Get("/v1/ready");
  REQUIRE(full);
  CHECK(full->status == 503);
  CHECK(full->get_header_value("Content-Type") == "application/problem+json");
  CHECK(full->body.find("server-busy") != std::string::npos);
  CHECK(full->body.find("full: 1 of 1 sessions") != std::string::npos);
  // Liveness is unaffected: the server still serves its session.
  httplib::Result health = client.Get("/v1/health");
  REQUIRE(health);
  CHECK(health->status == 200);
  const json session = json::parse(created->body);
  httplib::Result deleted = client.Delete(
      "/v1/sessions/" + session.at("id").get<std::string>(),
      httplib::Headers{{"Authorization", "Bearer " + session.at("token").get<std::string>()}});
  REQUIRE(deleted);
  CHECK(deleted->status == 204);
  httplib::Result readyAgain = client.Get("/v1/ready");
  REQUIRE(readyAgain);
  CHECK(readyAgain->status == 200);
  requireCleanStop(server);
}
