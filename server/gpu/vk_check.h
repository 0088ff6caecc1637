#pragma once

#include <stdexcept>
#include <string>

#include <vulkan/vulkan.h>

namespace myriad::gpu {

// A Vulkan call failed. Carries the call site so the log says where.
class VulkanError : public std::runtime_error {
 public:
  VulkanError(VkResult result, const char* expression, const char* file, int line);
  VkResult result;
};

const char* resultName(VkResult result);

}  // namespace myriad::gpu

// Runs `call` exactly once (also in release builds) and throws VulkanError unless VK_SUCCESS.
#define VK_CHECK(call)                                                          \
  do {                                                                          \
    VkResult vk_check_result_ = (call);                                         \
    if (vk_check_result_ != VK_SUCCESS) {                                       \
      throw ::myriad::gpu::VulkanError(vk_check_result_, #call, __FILE__, __LINE__); \
    }                                                                           \
  } while (0)
