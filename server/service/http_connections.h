// Connections as the network brings them, before httplib sees a byte (issue 31). httplib 0.11
// gives each connection a worker thread for its whole life and reads lines without bound, so 32
// slow clients took /v1/health down and a 300 MB header line was held in memory. Here one thread
// (epoll) holds every connection that is idle or still sending its request head, reads heads with
// the bounds of http_head.h and a deadline, caps connections in all and per client (the oldest
// waiting one gives way to a new one), and hands a complete head to a worker, which runs httplib's
// request processing over a stream that serves the bytes already read, bounds body reads (stall,
// rate, framing) and writes (a reader that takes nothing for the stall limit is cut off). Probes
// (health, ready, metrics) have workers of their own, so they answer under any flood. A finished
// connection goes back to the epoll thread; a worker never waits on an idle client.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>

#include "service/http_head.h"

namespace myriad::service {

struct ConnectionLimits {
  http::HeadLimits head;
  // The whole head of a request must arrive within this (nginx: client_header_timeout, 60 s).
  std::chrono::milliseconds headTimeout{10000};
  // A kept-alive connection with no new request is closed after this.
  std::chrono::milliseconds idleTimeout{2000};
  // A body read that gets no byte for this long fails; after it, a body must also keep arriving
  // at minBodyRate on average (a client trickling a byte a second cannot hold a worker).
  std::chrono::milliseconds readStall{10000};
  uint64_t minBodyRate = 4096;  // bytes per second
  // Open connections, in all and from one address; at the cap the longest-waiting idle or
  // partial connection is closed for the new one, or the new one gets 503 when none waits.
  uint32_t maxConnections = 4096;
  uint32_t maxConnectionsPerClient = 512;
  uint32_t workers = 32;       // run requests
  uint32_t probeWorkers = 2;   // run only probes
  uint32_t maxRequestsPerConnection = 1000;
};

// What the connection layer has done, for /metrics.
struct ConnectionCounts {
  uint64_t open = 0;
  uint64_t accepted = 0;
  uint64_t refusedAtCap = 0;   // 503: every connection busy
  uint64_t evicted = 0;        // waiting connections closed for newer ones
  uint64_t headTimeouts = 0;   // 408
  uint64_t headRefused = 0;    // 400, 414, 431, 501, 505 before any handler ran
};

class BoundedHttpServer : public httplib::Server {
 public:
  // Whether a request goes to the probe workers.
  using IsProbe = std::function<bool(const http::RequestHead&)>;

  BoundedHttpServer(const ConnectionLimits& limits, IsProbe isProbe);
  ~BoundedHttpServer() override;
  BoundedHttpServer(const BoundedHttpServer&) = delete;
  BoundedHttpServer& operator=(const BoundedHttpServer&) = delete;

  // After bind: a listen backlog for a burst of connections (httplib asks for 5).
  void widenBacklog();

  ConnectionCounts counts() const;

  // For the post-routing handler, on the worker writing the response: adds "Connection: close"
  // when the connection will not be kept (a body left unread, the client asked, a cap), so the
  // response says what happens.
  static void markClosing(httplib::Response& res);

 private:
  bool process_and_close_socket(socket_t sock) override;

  class Hub;
  std::unique_ptr<Hub> hub_;
};

}  // namespace myriad::service
