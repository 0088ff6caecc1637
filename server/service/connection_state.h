// The HTTP layer's side of service/connection.h: what it reads back, per worker thread.
#pragma once

#include <chrono>

#include "service/connection.h"

namespace myriad::service::connection {

std::chrono::milliseconds writeStallLimit();
void resetForRequest();  // before each request a worker runs

}  // namespace myriad::service::connection
