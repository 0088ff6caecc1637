// What the server says about the device it renders with (GET /v1/info "device", the start-up
// log). Plain data with no Vulkan in it, so the service can show it without seeing gpu/: the
// render thread copies it from gpu::DeviceInfo once at start-up.
#pragma once

#include <cstdint>
#include <string>

namespace myriad::render {

struct DeviceSummary {
  std::string name;        // "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H200"
  std::string type;        // "discrete-gpu", "integrated-gpu", "virtual-gpu", "cpu", "other"
  std::string driverName;  // VkPhysicalDeviceDriverProperties::driverName
  std::string driverInfo;  // VkPhysicalDeviceDriverProperties::driverInfo
  std::string apiVersion;  // "1.3.230"
  uint32_t vendorId = 0;
  uint32_t deviceId = 0;
  uint32_t index = 0;      // position in vkEnumeratePhysicalDevices
  bool isCpu = false;      // a software implementation (lavapipe, SwiftShader)
  uint32_t maxImageDimension2D = 0;
  uint64_t maxStorageBufferRange = 0;
  uint32_t maxComputeSharedMemorySize = 0;
  uint32_t subgroupSize = 0;
  double timestampPeriodNs = 0.0;
  bool timestampsSupported = false;
};

}  // namespace myriad::render
