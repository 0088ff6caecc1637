#include "service/http_connections.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <linux/sockios.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "protocol/constants.h"
#include "service/connection_state.h"
#include "service/problem.h"

namespace myriad::service {
namespace {

using Clock = std::chrono::steady_clock;

// A connection being closed after a refusal is read (and the bytes dropped) for this long or this
// much, so the client sees the response rather than a reset for the bytes it had still sent.
constexpr std::chrono::milliseconds kLingerTime{1000};
constexpr size_t kLingerBytes = 1 << 20;
// Bytes read from a socket at a time while it sends its head.
constexpr size_t kReadChunk = 16384;

const char* reasonPhrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 408: return "Request Timeout";
    case 414: return "URI Too Long";
    case 431: return "Request Header Fields Too Large";
    case 501: return "Not Implemented";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Error";
  }
}

// A whole response written by the connection layer itself (no handler ran), closing the
// connection.
std::string directResponse(const Problem& problem) {
  const std::string body = toBody(problem);
  std::string out = "HTTP/1.1 " + std::to_string(problem.status) + " " +
                    reasonPhrase(problem.status) + "\r\nContent-Type: " +
                    std::string(protocol::kProblemContentType) + "\r\n";
  if (problem.retryAfterSeconds) {
    out += std::string(protocol::headers::kRetryAfter) + ": " +
           std::to_string(*problem.retryAfterSeconds) + "\r\n";
  }
  out += "Content-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n";
  return out + body;
}

Problem headProblem(const http::HeadRefusal& refusal) {
  return badRequest(refusal.status, refusal.detail);
}

void addressOf(int fd, bool peer, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  const int result = peer ? getpeername(fd, reinterpret_cast<sockaddr*>(&address), &length)
                          : getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  if (result != 0) return;
  std::array<char, INET6_ADDRSTRLEN> text{};
  if (address.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&address);
    inet_ntop(AF_INET, &v4->sin_addr, text.data(), text.size());
    port = ntohs(v4->sin_port);
  } else if (address.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&address);
    inet_ntop(AF_INET6, &v6->sin6_addr, text.data(), text.size());
    port = ntohs(v6->sin6_port);
  }
  ip = text.data();
}

// Waits for `events` on `fd` up to `limit`; true when they (or an error or hang-up, which the next
// call reports) arrived.
bool waitFor(int fd, short events, std::chrono::milliseconds limit) {
  const Clock::time_point deadline = Clock::now() + limit;
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    pollfd entry{fd, events, 0};
    const int ready = poll(&entry, 1, static_cast<int>(std::max<int64_t>(left, 0)));
    if (ready > 0) return true;
    if (ready == 0) return false;
    if (errno != EINTR) return true;
  }
}

// Bytes written to `fd` that the peer has not yet acknowledged (the send queue); -1 unknown.
int unacknowledged(int fd) {
  int bytes = 0;
  return ioctl(fd, SIOCOUTQ, &bytes) == 0 ? bytes : -1;
}

// Waits until `fd` may take more bytes. False when the peer took no byte for `stall`: progress is
// the send queue shrinking, not POLLOUT, which waits for a third of the send buffer to drain, so a
// slow reader that takes a few kilobytes a second is not taken for one that stopped.
bool waitWritable(int fd, std::chrono::milliseconds stall) {
  constexpr std::chrono::milliseconds kLook{250};
  int queued = unacknowledged(fd);
  Clock::time_point deadline = Clock::now() + stall;
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    pollfd entry{fd, POLLOUT, 0};
    const int ready =
        poll(&entry, 1, static_cast<int>(std::clamp<int64_t>(left.count(), 0, kLook.count())));
    if (ready > 0 || (ready < 0 && errno != EINTR)) return true;
    const int now = unacknowledged(fd);
    if (now >= 0 && now < queued) return true;  // taken: try to write the room it made
    queued = now;
    if (Clock::now() >= deadline) return false;
  }
}

// httplib reads a body for these methods (detail::expect_content); for the others a body is
// never read, so the connection cannot carry another request after it.
bool bodyIsRead(const std::string& method) {
  return method == "POST" || method == "PUT" || method == "PATCH" || method == "DELETE";
}

struct Conn {
  int fd = -1;
  std::string peerIp;
  int peerPort = 0;
  std::string localIp;
  int localPort = 0;
  std::string buffer;  // read and not yet used: a head so far, or what followed the last request
  std::optional<http::HeadScanner> scanner;
  enum class Phase { Idle, Head, Lingering } phase = Phase::Idle;
  Clock::time_point deadline;
  Clock::time_point waitingSince;
  uint32_t served = 0;
  size_t drained = 0;
};

// httplib's view of one request on a connection: the bytes the epoll thread already read, then
// the socket, with every wait bounded.
class ConnStream final : public httplib::Stream {
 public:
  ConnStream(Conn& conn, const http::RequestHead& head, size_t headBytes,
             const ConnectionLimits& limits)
      : conn_(conn), head_(head), headBytes_(headBytes), limits_(limits) {}

  bool is_readable() const override {
    return pos_ < conn_.buffer.size() || waitFor(conn_.fd, POLLIN, limits_.readStall);
  }
  bool is_writable() const override {
    return !failed_ && waitWritable(conn_.fd, connection::writeStallLimit());
  }

  ssize_t read(char* ptr, size_t size) override {
    if (failed_) return -1;
    // Never past this request's end: what follows belongs to the next request. A request with
    // neither Content-Length nor chunked framing has an empty body (RFC 9112 section 6.3); httplib
    // would otherwise read a DELETE's "body" until the connection closed.
    if (consumed_ < headBytes_) {
      size = std::min<uint64_t>(size, headBytes_ - consumed_);
    } else if (!head_.hasBody() || (head_.chunked && framing_.done())) {
      return 0;
    } else if (head_.contentLength) {
      const uint64_t left = *head_.contentLength - bodyRead_;
      if (left == 0) return 0;
      size = std::min<uint64_t>(size, left);
    }
    size_t n = 0;
    if (pos_ < conn_.buffer.size()) {
      n = std::min(size, conn_.buffer.size() - pos_);
      std::memcpy(ptr, conn_.buffer.data() + pos_, n);
      pos_ += n;
    } else {
      while (true) {
        if (!waitFor(conn_.fd, POLLIN, limits_.readStall)) return fail();
        const ssize_t got = recv(conn_.fd, ptr, size, 0);
        if (got > 0) {
          n = static_cast<size_t>(got);
          break;
        }
        if (got == 0) return 0;
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return fail();
      }
    }
    return account(ptr, n) ? static_cast<ssize_t>(n) : fail();
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (failed_) return -1;
    size_t sent = 0;
    while (sent < size) {
      const ssize_t put = send(conn_.fd, ptr + sent, size - sent, MSG_NOSIGNAL);
      if (put > 0) {
        sent += static_cast<size_t>(put);
      } else if (put < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        // The stall limit counts from the last byte taken, not from the start of the response:
        // a slow reader of a large frame keeps its connection while it keeps reading.
        if (!waitWritable(conn_.fd, connection::writeStallLimit())) return fail();
      } else if (put < 0 && errno == EINTR) {
        continue;
      } else {
        return fail();
      }
    }
    return static_cast<ssize_t>(size);
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = conn_.peerIp;
    port = conn_.peerPort;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = conn_.localIp;
    port = conn_.localPort;
  }
  socket_t socket() const override { return conn_.fd; }

  bool failed() const { return failed_; }
  // Whether the request's body has been read to its end (so the next bytes are a new request).
  bool bodyFinished() const {
    if (!head_.hasBody()) return true;
    if (head_.chunked) return framing_.done();
    return bodyRead_ >= *head_.contentLength;
  }
  std::string unread() const { return conn_.buffer.substr(std::min(pos_, conn_.buffer.size())); }
  void setBodyLimit(uint64_t bytes) { bodyLimit_ = bytes; }

 private:
  ssize_t fail() {
    failed_ = true;
    return -1;
  }

  // Counts the body bytes among `n` just read (a read is all head or all body); false when they
  // break a bound.
  bool account(const char* ptr, size_t n) {
    const bool body = consumed_ >= headBytes_;
    consumed_ += n;
    if (!body) return true;
    bodyRead_ += n;
    if (head_.chunked && !framing_.feed(std::string_view(ptr, n))) return false;
    // The route's limit, plus room for chunked framing (a chunk of a byte costs five more).
    if (bodyRead_ > bodyLimit_ + bodyLimit_ / 8 + 65536) return false;
    const double elapsed = std::chrono::duration<double>(Clock::now() - started_).count();
    const double grace = std::chrono::duration<double>(limits_.readStall).count();
    if (elapsed > grace && static_cast<double>(bodyRead_) <
                               static_cast<double>(limits_.minBodyRate) * (elapsed - grace)) {
      return false;
    }
    return true;
  }

  Conn& conn_;
  const http::RequestHead& head_;
  const uint64_t headBytes_;
  const ConnectionLimits& limits_;
  const Clock::time_point started_ = Clock::now();
  size_t pos_ = 0;
  uint64_t consumed_ = 0;
  uint64_t bodyRead_ = 0;
  uint64_t bodyLimit_ = UINT64_MAX / 2;
  http::ChunkedFraming framing_;
  bool failed_ = false;
};

// What the worker thread now running a request knows about its connection, for markClosing and
// the handlers' hooks (connection_state.h).
struct CurrentRequest {
  ConnStream* stream = nullptr;
  bool closing = false;
};
thread_local CurrentRequest tCurrent;

}  // namespace

namespace connection {
void setBodyLimit(uint64_t bytes) {
  if (tCurrent.stream != nullptr) tCurrent.stream->setBodyLimit(bytes);
}
}  // namespace connection

class BoundedHttpServer::Hub {
 public:
  Hub(BoundedHttpServer& server, const ConnectionLimits& limits, IsProbe isProbe)
      : server_(server), limits_(limits), isProbe_(std::move(isProbe)) {
    epoll_ = epoll_create1(EPOLL_CLOEXEC);
    wake_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (epoll_ < 0 || wake_ < 0) {
      throw std::runtime_error(std::string("cannot set up connection polling: ") +
                               std::strerror(errno));
    }
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.fd = wake_;
    epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &event);
    thread_ = std::thread([this] { run(); });
    for (uint32_t i = 0; i < std::max(1u, limits_.workers); ++i) {
      requests_.threads.emplace_back([this] { work(requests_); });
    }
    for (uint32_t i = 0; i < std::max(1u, limits_.probeWorkers); ++i) {
      probes_.threads.emplace_back([this] { work(probes_); });
    }
  }

  ~Hub() {
    stop();
    close(epoll_);
    close(wake_);
  }

  // From the accepting thread.
  void accepted(int fd) {
    if (!post({Event::Kind::Accepted, Conn{.fd = fd}})) close(fd);
  }

  // Closes every waiting connection, answers what workers hold or have queued, joins all.
  void stop() {
    std::call_once(stopped_, [this] {
      stopping_ = true;
      wakeUp();
      if (thread_.joinable()) thread_.join();
      for (Pool* pool : {&requests_, &probes_}) {
        {
          std::lock_guard lock(pool->mutex);
          pool->stopping = true;
        }
        pool->ready.notify_all();
        for (std::thread& t : pool->threads) t.join();
      }
    });
  }

  ConnectionCounts counts() const {
    ConnectionCounts c;
    c.open = open_.load();
    c.accepted = accepted_.load();
    c.refusedAtCap = refusedAtCap_.load();
    c.evicted = evicted_.load();
    c.headTimeouts = headTimeouts_.load();
    c.headRefused = headRefused_.load();
    return c;
  }

 private:
  struct Event {
    enum class Kind { Accepted, Returned, Closing } kind;
    Conn conn;
  };
  struct Job {
    Conn conn;
    http::RequestHead head;
    size_t headBytes = 0;
  };
  struct Pool {
    std::mutex mutex;
    std::condition_variable ready;
    std::deque<Job> jobs;
    bool stopping = false;
    std::vector<std::thread> threads;
  };

  // False once the epoll thread has gone (the caller closes the socket itself).
  bool post(Event event) {
    {
      std::lock_guard lock(eventsMutex_);
      if (!running_) return false;
      events_.push_back(std::move(event));
    }
    wakeUp();
    return true;
  }

  void wakeUp() const {
    const uint64_t one = 1;
    [[maybe_unused]] ssize_t written = ::write(wake_, &one, sizeof one);
  }

  // The epoll thread.
  void run() {
    std::array<epoll_event, 128> ready{};
    while (!stopping_) {
      const int n = epoll_wait(epoll_, ready.data(), static_cast<int>(ready.size()), 100);
      for (int i = 0; i < n; ++i) {
        if (ready[static_cast<size_t>(i)].data.fd == wake_) {
          uint64_t value = 0;
          [[maybe_unused]] ssize_t got = ::read(wake_, &value, sizeof value);
        } else {
          onReadable(ready[static_cast<size_t>(i)].data.fd);
        }
      }
      handleEvents();
      expire(Clock::now());
    }
    std::vector<Event> left;
    {
      std::lock_guard lock(eventsMutex_);
      running_ = false;
      left.swap(events_);
    }
    for (Event& event : left) close(event.conn.fd);
    for (auto& [fd, conn] : waiting_) close(fd);
    waiting_.clear();
  }

  void handleEvents() {
    std::vector<Event> events;
    {
      std::lock_guard lock(eventsMutex_);
      events.swap(events_);
    }
    for (Event& event : events) {
      switch (event.kind) {
        case Event::Kind::Accepted:
          admit(event.conn.fd);
          break;
        case Event::Kind::Returned: {
          Conn& conn = event.conn;
          conn.phase = Conn::Phase::Idle;
          conn.deadline = Clock::now() + limits_.idleTimeout;
          conn.waitingSince = Clock::now();
          const int fd = conn.fd;
          const bool pipelined = !conn.buffer.empty();
          if (!enterWaiting(std::move(conn))) break;
          if (pipelined) {
            // The next request arrived with the last one: look at it now, not at the next read.
            auto it = waiting_.find(fd);
            it->second.phase = Conn::Phase::Head;
            it->second.deadline = Clock::now() + limits_.headTimeout;
            examine(it);
          }
          break;
        }
        case Event::Kind::Closing: {
          const int fd = event.conn.fd;
          if (!enterWaiting(std::move(event.conn))) break;
          linger(waiting_.find(fd));
          break;
        }
      }
    }
  }

  bool enterWaiting(Conn conn) {
    epoll_event event{};
    event.events = EPOLLIN | EPOLLRDHUP;
    event.data.fd = conn.fd;
    if (epoll_ctl(epoll_, EPOLL_CTL_ADD, conn.fd, &event) != 0) {
      forget(conn);
      return false;
    }
    const int fd = conn.fd;
    waiting_.emplace(fd, std::move(conn));
    return true;
  }

  using Waiting = std::unordered_map<int, Conn>;

  void admit(int fd) {
    accepted_.fetch_add(1);
    Conn conn;
    conn.fd = fd;
    addressOf(fd, true, conn.peerIp, conn.peerPort);
    addressOf(fd, false, conn.localIp, conn.localPort);
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    if (live_ >= limits_.maxConnections && !evictOldest(nullptr)) {
      refuseNow(fd, "The server has " + std::to_string(limits_.maxConnections) +
                        " connections open, its limit, and none is idle; retry shortly.");
      return;
    }
    if (perClient_[conn.peerIp] >= limits_.maxConnectionsPerClient &&
        !evictOldest(&conn.peerIp)) {
      refuseNow(fd, "This address has " + std::to_string(limits_.maxConnectionsPerClient) +
                        " connections open, the limit for one client, and none is idle.");
      return;
    }
    const int yes = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
    ++live_;
    ++perClient_[conn.peerIp];
    open_ = live_;
    // The first request's head is due within headTimeout of the connection opening.
    conn.phase = Conn::Phase::Idle;
    conn.deadline = Clock::now() + limits_.headTimeout;
    conn.waitingSince = Clock::now();
    enterWaiting(std::move(conn));
  }

  // At a cap: closes the waiting connection least likely to be missed (one already closing, then
  // the idle, then a partial head; the oldest of them), of `ip` when given. False when none waits.
  bool evictOldest(const std::string* ip) {
    auto rank = [](const Conn& c) {
      return c.phase == Conn::Phase::Lingering ? 0 : c.phase == Conn::Phase::Idle ? 1 : 2;
    };
    Waiting::iterator victim = waiting_.end();
    for (auto it = waiting_.begin(); it != waiting_.end(); ++it) {
      if (ip != nullptr && it->second.peerIp != *ip) continue;
      if (victim == waiting_.end() || rank(it->second) < rank(victim->second) ||
          (rank(it->second) == rank(victim->second) &&
           it->second.waitingSince < victim->second.waitingSince)) {
        victim = it;
      }
    }
    if (victim == waiting_.end()) return false;
    evicted_.fetch_add(1);
    closeWaiting(victim);
    return true;
  }

  void refuseNow(int fd, std::string detail) {
    refusedAtCap_.fetch_add(1);
    Problem problem = serverBusy(std::move(detail));
    problem.retryAfterSeconds = 1;
    const std::string response = directResponse(problem);
    [[maybe_unused]] ssize_t sent = send(fd, response.data(), response.size(), MSG_NOSIGNAL);
    close(fd);
  }

  void onReadable(int fd) {
    auto it = waiting_.find(fd);
    if (it == waiting_.end()) return;
    Conn& conn = it->second;
    if (conn.phase == Conn::Phase::Lingering) {
      std::array<char, kReadChunk> sink{};
      const ssize_t got = recv(fd, sink.data(), sink.size(), 0);
      if (got > 0) conn.drained += static_cast<size_t>(got);
      if (got == 0 || (got < 0 && errno != EAGAIN && errno != EINTR) ||
          conn.drained > kLingerBytes) {
        closeWaiting(it);
      }
      return;
    }
    if (!conn.scanner) conn.scanner.emplace(limits_.head);
    // One byte past the most a head may take, so a head over its bound is seen as such.
    const size_t room = conn.scanner->maxBuffer() + 1 - std::min(conn.buffer.size(),
                                                                 conn.scanner->maxBuffer() + 1);
    const size_t want = std::min(room, kReadChunk);
    if (want == 0) return;  // examine() has refused it already
    const size_t before = conn.buffer.size();
    conn.buffer.resize(before + want);
    const ssize_t got = recv(fd, conn.buffer.data() + before, want, 0);
    if (got <= 0) {
      conn.buffer.resize(before);
      if (got < 0 && (errno == EAGAIN || errno == EINTR)) return;
      closeWaiting(it);  // the client went away, between requests or mid-head
      return;
    }
    conn.buffer.resize(before + static_cast<size_t>(got));
    if (conn.phase == Conn::Phase::Idle) {
      conn.phase = Conn::Phase::Head;
      conn.deadline = Clock::now() + limits_.headTimeout;
    }
    examine(it);
  }

  void examine(Waiting::iterator it) {
    Conn& conn = it->second;
    if (!conn.scanner) conn.scanner.emplace(limits_.head);
    switch (conn.scanner->scan(conn.buffer)) {
      case http::HeadScanner::State::NeedMore:
        return;
      case http::HeadScanner::State::Refused:
        headRefused_.fetch_add(1);
        refuse(it, headProblem(conn.scanner->refusal()));
        return;
      case http::HeadScanner::State::Complete:
        break;
    }
    const size_t start = conn.scanner->headStart();
    const size_t end = conn.scanner->headEnd();
    http::ParsedHead parsed = http::parseHead(std::string_view(conn.buffer).substr(start, end - start));
    if (!parsed.head) {
      headRefused_.fetch_add(1);
      refuse(it, headProblem(parsed.refusal));
      return;
    }
    Job job;
    job.head = std::move(*parsed.head);
    job.headBytes = end - start;
    job.conn = std::move(conn);
    epoll_ctl(epoll_, EPOLL_CTL_DEL, job.conn.fd, nullptr);
    waiting_.erase(it);
    job.conn.buffer.erase(0, start);
    job.conn.scanner.reset();
    Pool& pool = isProbe_(job.head) ? probes_ : requests_;
    {
      std::lock_guard lock(pool.mutex);
      pool.jobs.push_back(std::move(job));
    }
    pool.ready.notify_one();
  }

  // Answers `problem` and closes the connection gracefully.
  void refuse(Waiting::iterator it, const Problem& problem) {
    const std::string response = directResponse(problem);
    [[maybe_unused]] ssize_t sent =
        send(it->first, response.data(), response.size(), MSG_NOSIGNAL);
    linger(it);
  }

  // No more is written; what the client still sends is read and dropped for a moment, then the
  // socket is closed (closing with unread bytes would reset the connection and could lose the
  // response on its way).
  void linger(Waiting::iterator it) {
    Conn& conn = it->second;
    shutdown(conn.fd, SHUT_WR);
    conn.phase = Conn::Phase::Lingering;
    conn.deadline = Clock::now() + kLingerTime;
    conn.waitingSince = Clock::now();
    conn.buffer = std::string();
    conn.scanner.reset();
    conn.drained = 0;
  }

  void expire(Clock::time_point now) {
    std::vector<int> due;
    for (const auto& [fd, conn] : waiting_) {
      if (conn.deadline <= now) due.push_back(fd);
    }
    for (int fd : due) {
      auto it = waiting_.find(fd);
      if (it->second.phase == Conn::Phase::Head) {
        headTimeouts_.fetch_add(1);
        const auto seconds =
            std::chrono::duration_cast<std::chrono::seconds>(limits_.headTimeout).count();
        refuse(it, badRequest(408, "The request head did not arrive whole within " +
                                       std::to_string(seconds) + " s."));
      } else {
        closeWaiting(it);
      }
    }
  }

  void closeWaiting(Waiting::iterator it) {
    epoll_ctl(epoll_, EPOLL_CTL_DEL, it->first, nullptr);
    forget(it->second);
    waiting_.erase(it);
  }

  void forget(const Conn& conn) {
    close(conn.fd);
    --live_;
    auto client = perClient_.find(conn.peerIp);
    if (client != perClient_.end() && --client->second == 0) perClient_.erase(client);
    open_ = live_;
  }

  // A worker thread.
  void work(Pool& pool) {
    while (true) {
      Job job;
      {
        std::unique_lock lock(pool.mutex);
        pool.ready.wait(lock, [&] { return pool.stopping || !pool.jobs.empty(); });
        if (pool.jobs.empty()) return;
        job = std::move(pool.jobs.front());
        pool.jobs.pop_front();
      }
      serve(job);
    }
  }

  void serve(Job& job) {
    Conn& conn = job.conn;
    connection::resetForRequest();
    ConnStream stream(conn, job.head, job.headBytes, limits_);
    const bool closeAfter = job.head.connectionClose || stopping_ ||
                            ++conn.served >= limits_.maxRequestsPerConnection ||
                            (job.head.hasBody() && !bodyIsRead(job.head.method));
    tCurrent = {&stream, closeAfter};
    bool closedByRequest = false;
    server_.process_request(stream, closeAfter, closedByRequest, nullptr);
    const bool keep = !tCurrent.closing && !closedByRequest && !stream.failed() &&
                      stream.bodyFinished();
    tCurrent = {};
    conn.buffer = stream.unread();
    const Event::Kind kind = keep ? Event::Kind::Returned : Event::Kind::Closing;
    const int fd = conn.fd;
    if (!post({kind, std::move(conn)})) close(fd);
  }

  friend class BoundedHttpServer;

  BoundedHttpServer& server_;
  const ConnectionLimits limits_;
  const IsProbe isProbe_;
  int epoll_ = -1;
  int wake_ = -1;

  std::mutex eventsMutex_;
  std::vector<Event> events_;
  bool running_ = true;  // the epoll thread takes events

  // The epoll thread's own.
  Waiting waiting_;
  uint64_t live_ = 0;  // connections open: waiting here or with a worker
  std::unordered_map<std::string, uint32_t> perClient_;

  std::atomic<bool> stopping_{false};
  std::atomic<uint64_t> open_{0}, accepted_{0}, refusedAtCap_{0}, evicted_{0}, headTimeouts_{0},
      headRefused_{0};

  Pool requests_;
  Pool probes_;
  std::thread thread_;
  std::once_flag stopped_;
};

namespace {
// httplib's accept loop hands each socket to its task queue; this one passes it to the hub at
// once (the accept loop never waits on a worker) and stops the hub when the loop ends.
class HandOff final : public httplib::TaskQueue {
 public:
  explicit HandOff(std::function<void()> onShutdown) : onShutdown_(std::move(onShutdown)) {}
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override { onShutdown_(); }

 private:
  std::function<void()> onShutdown_;
};
}  // namespace

BoundedHttpServer::BoundedHttpServer(const ConnectionLimits& limits, IsProbe isProbe)
    : hub_(std::make_unique<Hub>(*this, limits, std::move(isProbe))) {
  new_task_queue = [this] { return new HandOff([this] { hub_->stop(); }); };
  // Only for the Keep-Alive header httplib writes: the hub enforces both.
  set_keep_alive_timeout(
      std::max<time_t>(1, std::chrono::duration_cast<std::chrono::seconds>(limits.idleTimeout).count()));
  set_keep_alive_max_count(limits.maxRequestsPerConnection);
}

BoundedHttpServer::~BoundedHttpServer() { hub_->stop(); }

bool BoundedHttpServer::process_and_close_socket(socket_t sock) {
  hub_->accepted(sock);
  return true;
}

void BoundedHttpServer::widenBacklog() {
  const socket_t sock = svr_sock_;
  if (sock != INVALID_SOCKET) ::listen(sock, 1024);
}

ConnectionCounts BoundedHttpServer::counts() const { return hub_->counts(); }

void BoundedHttpServer::markClosing(httplib::Response& res) {
  CurrentRequest& current = tCurrent;
  if (current.stream == nullptr) return;
  if (res.get_header_value("Connection") == "close" || !current.stream->bodyFinished()) {
    current.closing = true;
  }
  if (current.closing && res.get_header_value("Connection") != "close") {
    res.set_header("Connection", "close");
  }
}

}  // namespace myriad::service
