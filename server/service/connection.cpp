#include "service/connection.h"

#include "service/connection_state.h"

namespace myriad::service::connection {

namespace {
thread_local std::chrono::milliseconds tWriteStall = kDefaultWriteStall;
}  // namespace

void setWriteStallLimit(std::chrono::milliseconds limit) { tWriteStall = limit; }

std::chrono::milliseconds writeStallLimit() { return tWriteStall; }

void resetForRequest() { tWriteStall = kDefaultWriteStall; }

}  // namespace myriad::service::connection
