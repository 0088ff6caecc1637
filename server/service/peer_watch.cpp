#include "service/peer_watch.h"

#include <dirent.h>
#include <linux/sockios.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/ioctl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace myriad::service {
namespace {

// "127.0.0.1", port: how httplib formats an address (getnameinfo, numeric host).
bool sameAddress(const sockaddr_storage& address, socklen_t length, const std::string& host,
                 int port) {
  char text[NI_MAXHOST];
  char service[NI_MAXSERV];
  if (getnameinfo(reinterpret_cast<const sockaddr*>(&address), length, text, sizeof text, service,
                  sizeof service, NI_NUMERICHOST | NI_NUMERICSERV) != 0) {
    return false;
  }
  return host == text && port == std::atoi(service);
}

}  // namespace

PeerWatch::PeerWatch(const std::string& localAddress, int localPort,
                     const std::string& remoteAddress, int remotePort) {
  if (localPort <= 0 || remotePort <= 0) return;
  DIR* fds = opendir("/proc/self/fd");
  if (fds == nullptr) return;
  const int self = dirfd(fds);
  while (dirent* entry = readdir(fds)) {
    char* end = nullptr;
    const long fd = std::strtol(entry->d_name, &end, 10);
    if (end == entry->d_name || *end != '\0' || fd == self) continue;
    sockaddr_storage local{};
    sockaddr_storage remote{};
    socklen_t localLength = sizeof local;
    socklen_t remoteLength = sizeof remote;
    // Not a socket, or not a connected one: getsockname/getpeername fail.
    if (getpeername(int(fd), reinterpret_cast<sockaddr*>(&remote), &remoteLength) != 0) continue;
    if (getsockname(int(fd), reinterpret_cast<sockaddr*>(&local), &localLength) != 0) continue;
    if (sameAddress(remote, remoteLength, remoteAddress, remotePort) &&
        sameAddress(local, localLength, localAddress, localPort)) {
      fd_ = int(fd);
      break;
    }
  }
  closedir(fds);
}

bool PeerWatch::gone() const {
  if (fd_ < 0) return false;
  pollfd watch{fd_, POLLIN | POLLRDHUP, 0};
  if (poll(&watch, 1, 0) <= 0) return false;
  if ((watch.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0) return true;
  // Readable without a hang-up: bytes the client sent after its request (pipelining), or the
  // end of file on kernels that report it as POLLIN alone.
  char byte;
  return recv(fd_, &byte, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
}

int64_t PeerWatch::unacknowledged() const {
  if (fd_ < 0) return -1;
  int bytes = 0;
  return ioctl(fd_, SIOCOUTQ, &bytes) == 0 ? int64_t(bytes) : -1;
}

uint32_t PeerWatch::roundTripUs() const {
  if (fd_ < 0) return 0;
  tcp_info info{};
  socklen_t length = sizeof info;
  if (getsockopt(fd_, IPPROTO_TCP, TCP_INFO, &info, &length) != 0) return 0;
  return info.tcpi_rtt;
}

}  // namespace myriad::service
