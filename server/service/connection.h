// What a route handler may ask of the HTTP connection it is answering on (service/http_server.cpp
// owns connections; it reads each request head itself, with bounds, before a worker runs it).
#pragma once

#include <chrono>
#include <cstdint>

namespace myriad::service::connection {

// A client that takes no byte of the response for this long loses the connection (the write
// fails, as if it had gone). Applies to the calling worker's current connection until its
// response is written; a long-lived stream sets a short limit so a reader that stopped reading
// frees its slot. Default: kDefaultWriteStall. Outside a request (a unit test) it does nothing.
inline constexpr std::chrono::milliseconds kDefaultWriteStall{30000};
void setWriteStallLimit(std::chrono::milliseconds limit);

// The most body bytes the current request may send, as the route allows, enforced on the raw
// bytes as they are read (framing included, with room for it), so a parser's own buffers (a
// multipart part's headers, a chunk-size line) cannot grow past it.
void setBodyLimit(uint64_t bytes);

}  // namespace myriad::service::connection
