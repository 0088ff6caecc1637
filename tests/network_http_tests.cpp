// The bare server against hostile and careless clients at the HTTP level (issue 31): slow and idle
// connections, oversized request lines and heads, bodies sent without a token, requests hidden in
// bodies, heads that never end, one address opening every connection. Each case measures what the
// server's memory and probes did, on raw sockets (a real client library would refuse to send most
// of this).
#include <doctest/doctest.h>
#include <httplib.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "raw_http.h"
#include "server_process.h"

using myriad::test::ServerProcess;
using Clock = std::chrono::steady_clock;

namespace {

using namespace myriad::test::raw;

void raiseOpenFileLimit() {
  rlimit limit{};
  getrlimit(RLIMIT_NOFILE, &limit);
  limit.rlim_cur = limit.rlim_max;
  setrlimit(RLIMIT_NOFILE, &limit);
}

struct Session {
  std::string id;
  std::string token;
};
Session createSession(const ServerProcess& server) {
  httplib::Client client(server.host(), server.port());
  httplib::Result created = client.Post("/v1/sessions", "{}", "application/json");
  REQUIRE(created);
  REQUIRE(created->status == 201);
  const nlohmann::json body = nlohmann::json::parse(created->body);
  return {body.at("id").get<std::string>(), body.at("token").get<std::string>()};
}

int sessionStatus(const ServerProcess& server, const Session& session) {
  httplib::Client client(server.host(), server.port());
  httplib::Result got = client.Get("/v1/sessions/" + session.id,
                                   {{"Authorization", "Bearer " + session.token}});
  return got ? got->status : 0;
}

double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const size_t index = std::min(values.size() - 1, size_t(p * double(values.size())));
  return values[index];
}

}  // namespace

TEST_CASE("network http: 1,000 slow connections (trickling and idle) leave /v1/health p99 <= 50 ms") {
  raiseOpenFileLimit();
  ServerProcess server({"--lights", "8"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  // Half say nothing; half send a head a byte at a time and never finish it.
  std::vector<int> slow;
  for (int i = 0; i < 1000; ++i) {
    const int fd = connectTo(server);
    REQUIRE(fd >= 0);
    if (i % 2 == 0) sendAll(fd, "GET /v1/info HTTP/1.1\r\nHost: x\r\n");
    slow.push_back(fd);
  }
  std::atomic<bool> done{false};
  std::thread trickle([&] {
    while (!done) {
      for (size_t i = 0; i < slow.size(); i += 2) ::send(slow[i], "X", 1, MSG_NOSIGNAL | MSG_DONTWAIT);
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  });
  std::vector<double> milliseconds;
  int healthy = 0;
  for (int i = 0; i < 200; ++i) {
    const Clock::time_point start = Clock::now();
    const std::string response =
        request(server, "GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    milliseconds.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    if (response.starts_with("HTTP/1.1 200")) ++healthy;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // The other probes and an ordinary request are answered too.
  const std::string ready =
      request(server, "GET /v1/ready HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  const std::string metrics =
      request(server, "GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  const std::string info =
      request(server, "GET /v1/info HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  done = true;
  trickle.join();
  for (int fd : slow) ::close(fd);
  const double p50 = percentile(milliseconds, 0.5);
  const double p99 = percentile(milliseconds, 0.99);
  MESSAGE("/v1/health beside 1,000 slow connections: median ", p50, " ms, p99 ", p99, " ms, max ",
          percentile(milliseconds, 1.0), " ms (200 probes)");
  CHECK(healthy == 200);
  CHECK(p99 <= 50.0);
  CHECK(ready.starts_with("HTTP/1.1 200"));
  CHECK(metrics.starts_with("HTTP/1.1 200"));
  CHECK(info.starts_with("HTTP/1.1 200"));
  CHECK(server.stop()->cleanExit());
}

TEST_CASE("network http: a 300 MB request line, header line, header flood or body after a 413 costs no memory") {
  ServerProcess server({"--lights", "8"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  const uint64_t before = server.residentBytes();
  struct Attack {
    const char* name;
    std::string head;
    std::string filler;
    const char* status;
    const char* mentions;
  };
  const std::vector<Attack> attacks = {
      {"request line", "GET /", "a", "HTTP/1.1 414", "request line"},
      {"header line", "GET /v1/health HTTP/1.1\r\nX-Long: ", "a", "HTTP/1.1 431", "header line"},
      {"header flood", "GET /v1/health HTTP/1.1\r\n", "X-Flood: 1\r\n", "HTTP/1.1 431",
       "header fields"},
      {"body after a 413",
       "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
       "Content-Length: 314572800\r\n\r\n",
       "GET /v1/info HTTP/1.1\r\nHost: x\r\n\r\n", "HTTP/1.1 413", "maxBodyBytes"},
  };
  for (const Attack& attack : attacks) {
    CAPTURE(attack.name);
    const Flood result = flood(server, attack.head, attack.filler, 300 * kMiB);
    INFO("response: ", result.response.substr(0, 400));
    MESSAGE(std::string(attack.name), ": ", result.sent / kMiB, " MiB sent before the server closed; peak RSS +",
            (result.peakResident - std::min(result.peakResident, before)) / kMiB, " MiB");
    CHECK(result.response.starts_with(attack.status));
    CHECK(result.response.find(attack.mentions) != std::string::npos);
    CHECK(result.response.find("Connection: close") != std::string::npos);
    CHECK(result.sent < 300 * kMiB);
    CHECK(result.peakResident <= before + 32 * kMiB);
    // Nothing after the answer ran: one response only.
    CHECK(result.response.find("HTTP/1.1", 1) == std::string::npos);
  }
  CHECK(server.residentBytes() <= before + 16 * kMiB);
  const std::string health =
      request(server, "GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  CHECK(health.starts_with("HTTP/1.1 200"));
  CHECK(server.stop()->cleanExit());
}

TEST_CASE("network http: unauthenticated multipart uploads are refused before their body is read") {
  ServerProcess server({"--lights", "8", "--api-key", "network-test-key"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  httplib::Client client(server.host(), server.port());
  httplib::Result created = client.Post("/v1/sessions", {{"Authorization", "Bearer network-test-key"}},
                                        "{}", "application/json");
  REQUIRE(created);
  REQUIRE(created->status == 201);
  const nlohmann::json body = nlohmann::json::parse(created->body);
  const Session session{body.at("id").get<std::string>(), body.at("token").get<std::string>()};
  const uint64_t before = server.residentBytes();

  // Empty parts, chunk after chunk: what made the server read 200 MB whole before the token.
  std::string parts;
  while (parts.size() < 64 * 1024) parts += "--B\r\nContent-Disposition: form-data; name=\"p\"\r\n\r\n\r\n";
  char size[16];
  std::snprintf(size, sizeof size, "%zx\r\n", parts.size());
  const std::string chunk = size + parts + "\r\n";
  auto upload = [&](const std::string& path, const std::string& authorization) {
    return "POST " + path + " HTTP/1.1\r\nHost: x\r\n" + authorization +
           "Content-Type: multipart/form-data; boundary=B\r\nTransfer-Encoding: chunked\r\n\r\n";
  };
  const std::string assets = "/v1/sessions/" + session.id + "/assets";
  const std::vector<std::string> heads = {
      upload(assets, ""),
      upload(assets, "Authorization: Bearer not-the-token\r\n"),
      upload("/v1/sessions", ""),  // the API key is checked before the body too
      upload(assets, ""),
  };
  std::vector<Flood> results(heads.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < heads.size(); ++i) {
    threads.emplace_back([&, i] { results[i] = flood(server, heads[i], chunk, 200 * kMiB); });
  }
  for (std::thread& t : threads) t.join();
  for (size_t i = 0; i < heads.size(); ++i) {
    CAPTURE(i);
    INFO("response: ", results[i].response.substr(0, 400));
    MESSAGE("unauthenticated upload ", i, ": ", results[i].sent / kMiB, " MiB sent, peak RSS +",
            (results[i].peakResident - std::min(results[i].peakResident, before)) / kMiB, " MiB");
    CHECK(results[i].response.starts_with("HTTP/1.1 401"));
    CHECK(results[i].response.find("Connection: close") != std::string::npos);
    CHECK(results[i].sent <= 16 * kMiB);  // socket buffers and the linger, not the body
  }
  CHECK(server.peakResidentBytes() <= before + 32 * kMiB);

  // With the token, the same body is cut by the part count, not read whole.
  const Flood authorized = flood(
      server, upload(assets, "Authorization: Bearer " + session.token + "\r\n"), chunk, 200 * kMiB);
  INFO("authorized response: ", authorized.response.substr(0, 400));
  CHECK(authorized.response.starts_with("HTTP/1.1 413"));
  CHECK(authorized.response.find("parts") != std::string::npos);
  CHECK(authorized.sent <= 16 * kMiB);
  CHECK(server.peakResidentBytes() <= before + 32 * kMiB);
  CHECK(server.stop()->cleanExit());
}

TEST_CASE("network http: a request hidden in a body is never executed") {
  ServerProcess server({"--lights", "8"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  const Session session = createSession(server);
  const std::string hidden = "DELETE /v1/sessions/" + session.id +
                             " HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + session.token +
                             "\r\n\r\n";
  const std::string length = std::to_string(hidden.size());
  char chunkSize[16];
  std::snprintf(chunkSize, sizeof chunkSize, "%zx\r\n", hidden.size());
  struct Case {
    const char* name;
    std::string bytes;
    const char* status;
  };
  const std::vector<Case> cases = {
      {"GET with Content-Length",
       "GET /v1/health HTTP/1.1\r\nHost: x\r\nContent-Length: " + length + "\r\n\r\n" + hidden,
       "HTTP/1.1 200"},
      {"HEAD with Content-Length",
       "HEAD /v1/health HTTP/1.1\r\nHost: x\r\nContent-Length: " + length + "\r\n\r\n" + hidden,
       "HTTP/1.1 200"},
      {"GET chunked",
       "GET /v1/health HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n" +
           std::string(chunkSize) + hidden + "\r\n0\r\n\r\n",
       "HTTP/1.1 200"},
      {"Content-Length with Transfer-Encoding",
       "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Length: 4\r\n"
       "Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n" + hidden,
       "HTTP/1.1 400"},
      {"two Content-Lengths",
       "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\nContent-Length: 0\r\n\r\n{}" +
           hidden,
       "HTTP/1.1 400"},
      {"a coding other than chunked",
       "POST /v1/sessions HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: gzip, chunked\r\n\r\n" + hidden,
       "HTTP/1.1 501"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const std::string response = request(server, c.bytes, std::chrono::seconds(5));
    INFO("response: ", response.substr(0, 400));
    CHECK(response.starts_with(c.status));
    CHECK(response.find("Connection: close") != std::string::npos);
    CHECK(response.find("HTTP/1.1", 1) == std::string::npos);  // one answer: the hidden one never ran
    CHECK(sessionStatus(server, session) == 200);
  }
  // Two requests sent together on one connection (pipelining) are both answered, in order.
  const std::string both = request(
      server, "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\nGET /v1/info HTTP/1.1\r\nHost: x\r\n"
              "Connection: close\r\n\r\n");
  CHECK(both.starts_with("HTTP/1.1 200"));
  CHECK(both.find("\"server\"") != std::string::npos);
  CHECK(server.stop()->cleanExit());
}

TEST_CASE("network http: a head that never ends gets 408 at --header-timeout and frees its place") {
  ServerProcess server({"--lights", "8", "--header-timeout", "1"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  const int fd = connectTo(server);
  REQUIRE(fd >= 0);
  const Clock::time_point start = Clock::now();
  sendAll(fd, "GET /v1/health HTTP/1.1\r\nHost: x\r\n");
  const std::string response = readUntilClosed(fd, std::chrono::seconds(5));
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  ::close(fd);
  INFO("response: ", response.substr(0, 400));
  MESSAGE("a head left unfinished was answered and closed after ", seconds, " s (timeout 1 s)");
  CHECK(response.starts_with("HTTP/1.1 408"));
  CHECK(seconds >= 0.9);
  CHECK(seconds <= 2.5);
  CHECK(server.stop()->cleanExit());
}

TEST_CASE("network http: one address cannot hold every connection") {
  ServerProcess server({"--lights", "8", "--max-connections-per-client", "20"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  std::vector<int> idle;
  for (int i = 0; i < 25; ++i) {
    idle.push_back(connectTo(server));
    REQUIRE(idle.back() >= 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  // The five that waited longest gave way to the newer ones: the server closed them.
  int closed = 0;
  for (int fd : idle) {
    std::string ignored;
    if (!drainNow(fd, ignored)) ++closed;
  }
  CHECK(closed == 5);
  std::string ignored;
  CHECK(!drainNow(idle.front(), ignored));
  CHECK(drainNow(idle.back(), ignored));
  // A probe from the same address still gets in (another idle one gives way), and /metrics
  // counts what gave way.
  const std::string health =
      request(server, "GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  CHECK(health.starts_with("HTTP/1.1 200"));
  const std::string metrics =
      request(server, "GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  const std::string evictedName = "\nmyriad_connections_evicted_total ";
  const size_t evictedAt = metrics.find(evictedName);
  REQUIRE(evictedAt != std::string::npos);
  CHECK(std::stoi(metrics.substr(evictedAt + evictedName.size())) >= 6);
  for (int fd : idle) ::close(fd);
  CHECK(server.stop()->cleanExit());
}
