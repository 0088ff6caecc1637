#include "raw_http.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace myriad::test::raw {

using Clock = std::chrono::steady_clock;

int connectTo(const ServerProcess& server) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(uint16_t(server.port()));
  ::inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  timeval timeout{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  return fd;
}

bool sendAll(int fd, const std::string& bytes) {
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += size_t(n);
  }
  return true;
}

bool drainNow(int fd, std::string& into) {
  char buffer[16384];
  while (true) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n > 0) {
      into.append(buffer, size_t(n));
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    return false;
  }
}

std::string readUntilClosed(int fd, std::chrono::milliseconds timeout) {
  std::string response;
  const Clock::time_point deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    pollfd entry{fd, POLLIN, 0};
    ::poll(&entry, 1, 50);
    if (!drainNow(fd, response)) break;
  }
  return response;
}

std::string request(const ServerProcess& server, const std::string& bytes,
                    std::chrono::milliseconds timeout) {
  const int fd = connectTo(server);
  if (fd < 0) return {};
  sendAll(fd, bytes);
  std::string response = readUntilClosed(fd, timeout);
  ::close(fd);
  return response;
}

Flood flood(const ServerProcess& server, const std::string& head, const std::string& filler,
            uint64_t total) {
  Flood result;
  const int fd = connectTo(server);
  if (fd < 0) return result;
  bool open = sendAll(fd, head);
  std::string block;
  while (block.size() < kMiB) block += filler;
  while (open && result.sent < total) {
    open = sendAll(fd, block) && drainNow(fd, result.response);
    if (open) result.sent += block.size();
    if (result.response.find("\r\n\r\n") != std::string::npos) break;
  }
  const std::string rest = readUntilClosed(fd, std::chrono::seconds(3));
  result.response += rest;
  result.peakResident = server.peakResidentBytes();
  ::close(fd);
  return result;
}

Flood upload(const ServerProcess& server, const std::string& head, const std::string& body) {
  Flood result;
  const int fd = connectTo(server);
  if (fd < 0) return result;
  bool open = sendAll(fd, head);
  for (size_t at = 0; open && at < body.size(); at += kMiB) {
    const std::string piece = body.substr(at, kMiB);
    open = sendAll(fd, piece) && drainNow(fd, result.response);
    if (open) result.sent += piece.size();
    if (result.response.find("\r\n\r\n") != std::string::npos) break;
  }
  result.response += readUntilClosed(fd, std::chrono::seconds(300));
  result.peakResident = server.peakResidentBytes();
  ::close(fd);
  return result;
}

}  // namespace myriad::test::raw
