// Streams as the network finds them (issue 31), against the real server over loopback: a stream
// lives only as long as the token it was opened with (revoked, expired, or its session deleted:
// it ends within 1 s, an image stream with a last problem part saying why), one session cannot
// take every stream slot, and a reader that stops reading gives its slot back within 5 s.
// Frames are tiny (64x36, 4 lights) so the whole CTest stays short on lavapipe; the longest case
// waits out the shortest viewer token the API makes (60 s).
#include <doctest/doctest.h>
#include <httplib.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "server_process.h"

using nlohmann::json;
using myriad::test::ApiClient;
using myriad::test::MultipartReader;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::StreamPart;
using myriad::test::TestSession;
using myriad::test::VideoReader;
using myriad::test::bearer;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::mintViewer;
using Clock = std::chrono::steady_clock;

namespace {

// The promise under test, and how long a case waits for what should take far less.
constexpr double kEndSeconds = 1.0;
constexpr double kStallSeconds = 5.0;
constexpr auto kFirstPart = std::chrono::seconds(120);  // a first frame on a busy lavapipe
constexpr auto kEndWait = std::chrono::seconds(10);

const std::string kImageQuery = "/stream?format=jpeg&fps=10&width=64&height=36";
const std::string kVideoQuery = "/stream?codec=vp8&fps=10&width=64&height=36";

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

// Waits for a reader's end; the seconds from `since`, or nullopt when it did not end.
template <typename Reader>
std::optional<double> endedAfter(Reader& reader, Clock::time_point since) {
  if (!reader.waitForEnd(kEndWait)) return std::nullopt;
  return secondsSince(since);
}

// The last part of an image stream that ended for a reason: a problem, whole and framed as every
// other part, of `status` and `type`, its detail saying `why`.
void checkLastPart(MultipartReader& reader, int status, const std::string& type,
                   const std::string& why) {
  INFO("framing: ", reader.framingError());
  CHECK(reader.framingError().empty());
  CHECK(reader.leftover() == 0);
  const std::vector<StreamPart> parts = reader.items();
  REQUIRE(parts.size() >= 2);  // a frame, then the problem
  CHECK(parts[parts.size() - 2].headers.at("Content-Type") == "image/jpeg");
  const StreamPart& last = parts.back();
  CHECK(last.headers.at("Content-Type") == "application/problem+json");
  CHECK(last.headers.count("X-Myriad-Frame") == 0);
  const json problem = json::parse(last.body, nullptr, false);
  INFO("last part: ", last.body);
  REQUIRE(problem.is_object());
  CHECK(problem.value("status", 0) == status);
  CHECK(problem.value("type", "") == "https://myriad.dev/problems/" + type);
  CHECK(problem.value("detail", "").find(why) != std::string::npos);
}

// A stream request expected to be refused: its answer. A stream that opens instead is cut at its
// headers (status 200), never read on.
Reply tryStream(const ServerProcess& server, const std::string& path, const std::string& token) {
  httplib::Client client(server.host(), server.port());
  client.set_read_timeout(60, 0);
  Reply reply;
  client.Get(
      path, bearer(token),
      [&](const httplib::Response& response) {
        reply.status = response.status;
        reply.headers = response.headers;
        return response.status != 200;
      },
      [&](const char* data, size_t size) {
        reply.body.append(data, size);
        return true;
      });
  if (reply.header("Content-Type").find("json") != std::string::npos) {
    reply.json = json::parse(reply.body, nullptr, false);
  }
  return reply;
}

// The myriad_streams gauge: streams holding a slot.
uint64_t openStreams(ApiClient& api) {
  Reply metrics = api.get("/metrics");
  REQUIRE(metrics.status == 200);
  const std::string name = "\nmyriad_streams ";
  const size_t at = metrics.body.find(name);
  REQUIRE(at != std::string::npos);
  return std::stoull(metrics.body.substr(at + name.size()));
}

// A client that asks for a stream on a socket with a small receive buffer and never reads: the
// server's writes stop making progress once the socket buffers on both ends are full.
class StalledReader {
 public:
  StalledReader(const ServerProcess& server, const std::string& path, const std::string& token) {
    fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    REQUIRE(fd_ >= 0);
    // Before connect, so the window the server sees is small from the start.
    const int receiveBuffer = 4096, segment = 536;
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receiveBuffer, sizeof receiveBuffer);
    setsockopt(fd_, IPPROTO_TCP, TCP_MAXSEG, &segment, sizeof segment);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(uint16_t(server.port()));
    REQUIRE(inet_pton(AF_INET, server.host().c_str(), &address.sin_addr) == 1);
    REQUIRE(connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0);
    const std::string request = "GET " + path + " HTTP/1.1\r\nHost: " + server.host() +
                                "\r\nAuthorization: Bearer " + token + "\r\n\r\n";
    REQUIRE(send(fd_, request.data(), request.size(), MSG_NOSIGNAL) == ssize_t(request.size()));
  }
  ~StalledReader() { close(fd_); }
  StalledReader(const StalledReader&) = delete;
  StalledReader& operator=(const StalledReader&) = delete;

  // Bytes the server sent that wait, unread, in this socket's receive queue.
  int queued() const {
    int bytes = 0;
    ioctl(fd_, FIONREAD, &bytes);
    return bytes;
  }

 private:
  int fd_ = -1;
};

}  // namespace

TEST_CASE("network streams: revoking a viewer link ends its image and video streams within 1 s") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession session = createSession(api);
  const std::string viewer = mintViewer(api, session, 3600);

  MultipartReader owner(server, session.path() + kImageQuery, bearer(session.token));
  MultipartReader image(server, session.path() + kImageQuery + "&token=" + viewer);
  VideoReader video(server, session.path() + kVideoQuery, bearer(viewer));
  REQUIRE(owner.status() == 200);
  REQUIRE(image.status() == 200);
  REQUIRE(video.status() == 200);
  REQUIRE(owner.waitFor(1, kFirstPart).size() == 1);
  REQUIRE(image.waitFor(1, kFirstPart).size() == 1);
  REQUIRE(video.waitFor(1, kFirstPart).size() == 1);

  // Timed from the request: the streams may end before its answer arrives.
  const Clock::time_point asked = Clock::now();
  REQUIRE(api.del(session.path() + "/tokens", session.token).status == 204);
  const double answered = secondsSince(asked);
  const std::optional<double> imageEnded = endedAfter(image, asked);
  const std::optional<double> videoEnded = endedAfter(video, asked);
  REQUIRE(imageEnded);
  REQUIRE(videoEnded);
  MESSAGE("DELETE .../tokens answered in ", answered,
          " s; the viewer's image stream had ended within ", *imageEnded, " s, its video stream ",
          *videoEnded, " s of it being sent");
  CHECK(*imageEnded < kEndSeconds);
  CHECK(*videoEnded < kEndSeconds);
  checkLastPart(image, 401, "unauthorized", "viewer link");
  CHECK(image.items().back().body.find("was revoked") != std::string::npos);
  // The video format has no chunk for a reason: its body just ends, whole.
  CHECK(video.framingError().empty());
  CHECK(video.leftover() == 0);
  CHECK(video.items().back().kind != 0);

  // The owner's stream goes on: an edit still reaches it.
  const size_t ownerParts = owner.items().size();
  REQUIRE(api.patch(session.path() + "/camera", R"({"fovY": 35})", session.token).status == 200);
  CHECK(owner.waitFor(ownerParts + 1, kFirstPart).size() > ownerParts);
  CHECK_FALSE(owner.waitForEnd(std::chrono::seconds(0)));
  // And the link opens nothing any more.
  checkProblem(tryStream(server, session.path() + kImageQuery, viewer), 401, "unauthorized",
               "stream with a revoked link");
  CHECK(myriad::test::validationMessages(api) == 0);
}

TEST_CASE("network streams: a viewer link's streams end within 1 s of its expiry") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession session = createSession(api);
  // The shortest token the API makes (token-create.schema.json: ttlSeconds 60 and up). The
  // server sets its expiry in whole seconds of the wall clock when it mints it: between these.
  constexpr int kTtl = 60;
  const auto unixSeconds = [] {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
        .count();
  };
  const double mintStart = unixSeconds();
  const std::string viewer = mintViewer(api, session, kTtl);
  const double mintEnd = unixSeconds();
  const double earliestExpiry = std::floor(mintStart) + kTtl;
  const double latestExpiry = std::floor(mintEnd) + kTtl;

  MultipartReader image(server, session.path() + kImageQuery + "&token=" + viewer);
  VideoReader video(server, session.path() + kVideoQuery, bearer(viewer));
  REQUIRE(image.status() == 200);
  REQUIRE(video.status() == 200);
  REQUIRE(image.waitFor(1, kFirstPart).size() == 1);
  REQUIRE(video.waitFor(1, kFirstPart).size() == 1);

  const auto waitAndTime = [&](auto& reader) -> std::optional<double> {
    const auto wait = std::chrono::seconds(int64_t(latestExpiry - unixSeconds()) + 10);
    if (!reader.waitForEnd(wait)) return std::nullopt;
    return unixSeconds();
  };
  const std::optional<double> imageEnd = waitAndTime(image);
  const std::optional<double> videoEnd = waitAndTime(video);
  REQUIRE(imageEnd);
  REQUIRE(videoEnd);
  MESSAGE("the link expired between ", earliestExpiry - mintStart, " and ",
          latestExpiry - mintStart, " s after it was asked for; its image stream ended ",
          *imageEnd - mintStart, " s, its video stream ", *videoEnd - mintStart, " s after");
  // Not before the token stopped working, and within a second after.
  CHECK(*imageEnd >= earliestExpiry);
  CHECK(*videoEnd >= earliestExpiry);
  CHECK(*imageEnd - latestExpiry < kEndSeconds);
  CHECK(*videoEnd - latestExpiry < kEndSeconds);
  checkLastPart(image, 401, "unauthorized", "viewer link");
  CHECK(image.items().back().body.find("expired") != std::string::npos);
  // It was live until then: idle re-sends every 2 s, the last within 2.5 s of the end.
  const std::vector<StreamPart> parts = image.items();
  CHECK(parts.size() >= 20);
  const double lastImageBeforeEnd =
      std::chrono::duration<double>(parts.back().arrived - parts[parts.size() - 2].arrived).count();
  CHECK(lastImageBeforeEnd < 2.5);
  CHECK(video.framingError().empty());
  CHECK(video.leftover() == 0);
  checkProblem(tryStream(server, session.path() + kImageQuery, viewer), 401, "unauthorized",
               "stream with an expired link");
}

TEST_CASE("network streams: deleting a session ends all its streams within 1 s") {
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession session = createSession(api);
  TestSession other = createSession(api);
  const std::string viewer = mintViewer(api, session, 3600);

  MultipartReader owner(server, session.path() + kImageQuery, bearer(session.token));
  MultipartReader watcher(server, session.path() + kImageQuery + "&token=" + viewer);
  VideoReader video(server, session.path() + kVideoQuery, bearer(session.token));
  MultipartReader elsewhere(server, other.path() + kImageQuery, bearer(other.token));
  for (MultipartReader* reader : {&owner, &watcher, &elsewhere}) {
    REQUIRE(reader->status() == 200);
    REQUIRE(reader->waitFor(1, kFirstPart).size() == 1);
  }
  REQUIRE(video.status() == 200);
  REQUIRE(video.waitFor(1, kFirstPart).size() == 1);

  // Timed from the request: DELETE answers once the GPU scene is freed, after the streams woke.
  const Clock::time_point asked = Clock::now();
  REQUIRE(api.del(session.path(), session.token).status == 204);
  const double answered = secondsSince(asked);
  const std::optional<double> ownerEnded = endedAfter(owner, asked);
  const std::optional<double> watcherEnded = endedAfter(watcher, asked);
  const std::optional<double> videoEnded = endedAfter(video, asked);
  REQUIRE(ownerEnded);
  REQUIRE(watcherEnded);
  REQUIRE(videoEnded);
  MESSAGE("DELETE answered in ", answered, " s; the owner's image stream had ended within ",
          *ownerEnded, " s, the viewer's ", *watcherEnded, " s, the video stream ", *videoEnded,
          " s of it being sent");
  CHECK(*ownerEnded < kEndSeconds);
  CHECK(*watcherEnded < kEndSeconds);
  CHECK(*videoEnded < kEndSeconds);
  checkLastPart(owner, 404, "not-found", "was deleted");
  checkLastPart(watcher, 404, "not-found", "was deleted");
  CHECK(video.framingError().empty());
  CHECK(video.leftover() == 0);
  // Another session's stream is untouched.
  CHECK_FALSE(elsewhere.waitForEnd(std::chrono::seconds(0)));
  CHECK(openStreams(api) == 1);
}

TEST_CASE("network streams: one session holds at most its share of the stream slots") {
  // 4 slots, 2 a session (the default share: half, rounded up).
  ServerProcess server({"--lights", "4", "--max-streams", "4"});
  requireListening(server);
  ApiClient api(server);
  TestSession greedy = createSession(api);
  TestSession other = createSession(api);
  const std::string viewer = mintViewer(api, greedy, 3600);

  std::optional<MultipartReader> first;
  first.emplace(server, greedy.path() + kImageQuery, bearer(greedy.token));
  MultipartReader second(server, greedy.path() + kImageQuery + "&token=" + viewer);
  REQUIRE(first->status() == 200);
  REQUIRE(second.status() == 200);
  REQUIRE(first->waitFor(1, kFirstPart).size() == 1);
  REQUIRE(second.waitFor(1, kFirstPart).size() == 1);

  // A third, with either token: over the session's share, while the server has slots left.
  for (const std::string& token : {greedy.token, viewer}) {
    Reply refused = tryStream(server, greedy.path() + kImageQuery, token);
    checkProblem(refused, 429, "limit-exceeded", "a third stream of one session", std::nullopt,
                 "maxStreamsPerSession");
    CHECK(refused.json.value("detail", "").find("--max-streams-per-session") !=
          std::string::npos);
  }
  CHECK(openStreams(api) == 2);
  // Neither of its open streams was given up for it.
  CHECK_FALSE(first->waitForEnd(std::chrono::seconds(0)));
  CHECK_FALSE(second.waitForEnd(std::chrono::seconds(0)));

  // Another session still gets its share.
  MultipartReader fromOther(server, other.path() + kImageQuery, bearer(other.token));
  REQUIRE(fromOther.status() == 200);
  CHECK(fromOther.waitFor(1, kFirstPart).size() == 1);
  CHECK(openStreams(api) == 3);

  // A stream whose client hung up gives its slot back at once (its client's socket is closed),
  // not at its next write up to 2 s later: the session's next stream opens.
  first.reset();
  const Clock::time_point closed = Clock::now();
  MultipartReader replacement(server, greedy.path() + kImageQuery, bearer(greedy.token));
  REQUIRE(replacement.status() == 200);
  MESSAGE("a stream opened ", secondsSince(closed), " s after the client of one closed");
  CHECK(replacement.waitFor(1, kFirstPart).size() == 1);
  CHECK(openStreams(api) == 3);
}

// The server gives up a write that takes no byte for 3 s (connection::setWriteStallLimit, set by
// every stream; stream.h kStreamWriteStall): the stream ends and frees its slot.
TEST_CASE("network streams: a reader that stops reading frees its slot within 5 s") {
  // One slot for the session, so a new stream opens only once the stalled one has let go.
  ServerProcess server({"--lights", "4", "--max-streams", "2", "--max-streams-per-session", "1"});
  requireListening(server);
  ApiClient api(server);
  TestSession session = createSession(api);
  // Animated: a new picture every frame, so a reader that reads would keep receiving.
  REQUIRE(api.patch(session.path() + "/settings", R"({"animate": true})", session.token).status ==
          200);
  const std::string query = "/stream?format=png&fps=30&width=320&height=180";
  StalledReader stalled(server, session.path() + query, session.token);

  // Its receive queue grows while the server writes, then stays put: the buffers are full.
  const Clock::time_point opened = Clock::now();
  int queued = 0;
  Clock::time_point lastGrowth = opened;
  while (Clock::now() - opened < std::chrono::seconds(120)) {
    const int now = stalled.queued();
    if (now != queued) {
      queued = now;
      lastGrowth = Clock::now();
    } else if (queued > 0 && Clock::now() - lastGrowth > std::chrono::seconds(1)) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  REQUIRE(queued > 0);
  MESSAGE("the stalled reader's socket holds ", queued, " unread bytes, full ",
          secondsSince(opened), " s after it asked");

  // From the last byte it took: the server's own buffer fills, its write stalls, fails after
  // 3 s, and the stream's slot goes.
  std::optional<double> freedAfter;
  while (secondsSince(lastGrowth) < 3 * kStallSeconds) {
    if (openStreams(api) == 0) {
      freedAfter = secondsSince(lastGrowth);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!freedAfter) {
    FAIL("the stalled stream still holds its slot ", secondsSince(lastGrowth),
         " s after its reader stopped taking bytes");
  }
  MESSAGE("the slot was free ", *freedAfter, " s after the reader stopped taking bytes");
  CHECK(*freedAfter < kStallSeconds);
  // The session streams again.
  MultipartReader next(server, session.path() + kImageQuery, bearer(session.token));
  REQUIRE(next.status() == 200);
  CHECK(next.waitFor(1, kFirstPart).size() == 1);
}
