// What the server says about the Vulkan device it renders with (GET /v1/info, the start-up log).
#pragma once

#include <cstdint>
#include <string>

namespace myriad::gpu {

struct DeviceInfo {
  std::string name;           // "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H200"
  std::string type;           // "discrete-gpu", "integrated-gpu", "virtual-gpu", "cpu", "other"
  std::string driverName;     // VkPhysicalDeviceDriverProperties::driverName
  std::string driverInfo;     // VkPhysicalDeviceDriverProperties::driverInfo
  std::string apiVersion;     // "1.3.230"
  uint32_t vendorId = 0;
  uint32_t deviceId = 0;
  uint32_t index = 0;         // position in vkEnumeratePhysicalDevices
  bool isCpu = false;         // a software implementation (lavapipe, SwiftShader)
  uint32_t maxImageDimension2D = 0;
  uint64_t maxStorageBufferRange = 0;
  uint64_t maxTexelBufferElements = 0;  // texels one texel-buffer view may cover
  uint32_t maxComputeSharedMemorySize = 0;
  uint32_t maxComputeWorkGroupInvocations = 0;
  uint32_t maxComputeWorkGroupSizeX = 0;
  uint32_t subgroupSize = 0;
  bool computeSubgroupShuffle = false;  // compute shaders have subgroup vote, arithmetic, ballot, shuffle
  // Streaming multiprocessors (VK_NV_shader_sm_builtins) or compute units
  // (VK_AMD_shader_core_properties), where the driver says; 0 unknown.
  uint32_t multiprocessors = 0;
  double timestampPeriodNs = 0.0;
  bool timestampsSupported = false;
};

}  // namespace myriad::gpu
