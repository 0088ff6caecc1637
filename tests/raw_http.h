// Raw HTTP on loopback sockets for the network tests: what a real client library would refuse
// to send (a 300 MB header line, a body after its refusal), and reading an answer while still
// sending, as a careful client does when a server may answer before the body is read.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "server_process.h"

namespace myriad::test::raw {

inline constexpr uint64_t kMiB = 1ull << 20;

// A connected socket (5 s send timeout), or -1.
int connectTo(const ServerProcess& server);
bool sendAll(int fd, const std::string& bytes);
// Whatever has arrived, without waiting; false once the server has closed (or reset) the socket.
bool drainNow(int fd, std::string& into);
// Reads until the server closes the connection or `timeout` passes.
std::string readUntilClosed(int fd, std::chrono::milliseconds timeout);
// One request on a new connection, closed after; the whole response.
std::string request(const ServerProcess& server, const std::string& bytes,
                    std::chrono::milliseconds timeout = std::chrono::seconds(10));

// What a sending client saw: the bytes it got through and the server's answer.
struct Flood {
  uint64_t sent = 0;
  std::string response;
  uint64_t peakResident = 0;  // the server's, after
};
// Sends `head`, then `filler` over and over up to `total` bytes, reading as it goes: stops when
// the server has answered, or refuses more bytes.
Flood flood(const ServerProcess& server, const std::string& head, const std::string& filler,
            uint64_t total);
// Sends `head` and `body` in 1 MiB pieces, reading as it goes; stops early as flood() does.
Flood upload(const ServerProcess& server, const std::string& head, const std::string& body);

}  // namespace myriad::test::raw
