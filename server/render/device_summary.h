// What the server says about the device it renders with (GET /v1/info "device", the start-up
// log): the protocol's own DeviceSummary, plain data with no Vulkan in it, so the service can show
// it without seeing gpu/. The render thread fills it from gpu::DeviceInfo once at start-up.
#pragma once

#include "protocol/types.h"

namespace myriad::render {

using DeviceSummary = protocol::DeviceSummary;

}  // namespace myriad::render
