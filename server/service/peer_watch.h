// Whether the client of a request is still connected, asked before spending a render on it.
//
// httplib 0.11 does not hand a handler its connection's socket, and a write to a socket whose
// peer has closed still succeeds once (the reset comes back after it), so a stream learned that
// its client was gone only after rendering and writing one or two more frames. PeerWatch finds
// the socket by the request's addresses (each accepted connection has a distinct local/remote
// address pair) and asks the kernel whether the peer has hung up.
#pragma once

#include <cstdint>
#include <string>

namespace myriad::service {

class PeerWatch {
 public:
  PeerWatch() = default;
  // The connected socket of this process whose local and remote addresses are these (as
  // httplib's Request gives them: numeric host, port); unknown (never gone) when none matches.
  PeerWatch(const std::string& localAddress, int localPort, const std::string& remoteAddress,
            int remotePort);

  bool found() const { return fd_ >= 0; }
  // True once the peer has closed its side or reset the connection. Never blocks. Valid while the
  // connection is open: httplib closes the socket only after the response's provider returns.
  bool gone() const;

  // Bytes written to the connection that the peer has not acknowledged yet (SIOCOUTQ: sent and
  // in flight, or still queued in the kernel); -1 when unknown. A stream learns from it how far
  // behind its client is (stream.h, "Delivery").
  int64_t unacknowledged() const;
  // The connection's smoothed round-trip time in microseconds (TCP_INFO), 0 when unknown.
  uint32_t roundTripUs() const;

 private:
  int fd_ = -1;
};

}  // namespace myriad::service
