// The Vulkan instance, the chosen physical device, the logical device and its one queue.
// Created once at start-up; owned by whoever renders (the render thread).
#pragma once

#include <atomic>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/device_info.h"

namespace myriad::gpu {

struct ContextOptions {
  bool validation = false;  // enable VK_LAYER_KHRONOS_validation and count its messages
  std::string device;       // "" = best available; else an index or a substring of the name
  // A diagnostic: compute pipelines print the driver's statistics (registers, local and shared
  // memory) where the device has VK_KHR_pipeline_executable_properties (pipelines.h,
  // capturePipelineStatistics). Set by `--tune pipeline-stats=on` (render/tuning.h).
  bool pipelineStatistics = false;
};

// No usable Vulkan 1.3 device, or --device matched none. The message is one actionable sentence.
class NoDeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Context {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  DeviceInfo info;
  VkPhysicalDeviceMemoryProperties memoryProperties{};
  bool depthClamp = false;
  // fragmentStoresAndAtomics: fragment shaders may write storage buffers (the clustered technique
  // marks the clusters of alpha-blended surfaces from their fragments).
  bool fragmentStores = false;
  // shaderInt64 and shaderBufferInt64Atomics: 64-bit atomicMin on storage buffers (the G-buffer
  // rasterised in compute, render/visibility.h, needs them; lavapipe and NVIDIA have them).
  bool int64Atomics = false;
  float maxAnisotropy = 0.0f;  // 0: samplerAnisotropy is not available (textures filter without it)

  // Validation-layer messages of warning or error severity seen so far (0 when validation is off).
  std::atomic<uint32_t> validationMessages{0};

  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context();
};

// Picks a discrete GPU, else an integrated one, else any other, else a CPU implementation; or the
// device named by options.device. Throws NoDeviceError when there is none.
std::unique_ptr<Context> createContext(const ContextOptions& options);

// Every Vulkan 1.3 device present, in enumeration order (for --device and error messages).
std::vector<DeviceInfo> listDevices();

// Which of `devices` to use: options.device as an index or name substring, else by type
// (discrete > integrated > virtual > other > cpu). Returns -1 when none matches.
int chooseDevice(const std::vector<DeviceInfo>& devices, const std::string& selector);

}  // namespace myriad::gpu
