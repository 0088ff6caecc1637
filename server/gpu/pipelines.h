// Graphics pipelines for dynamic rendering, described by a plain struct.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <vulkan/vulkan.h>

namespace myriad::gpu {

// Alpha: `over` (colour = src * src.a + dst * (1 - src.a), the destination's alpha kept).
enum class Blend { None, Additive, Alpha };

struct VertexLayout {
  uint32_t stride = 0;  // 0: no vertex buffer (fullscreen triangle)
  std::vector<VkVertexInputAttributeDescription> attributes;
};

struct GraphicsPipelineDesc {
  std::span<const uint32_t> vertexShader;
  std::span<const uint32_t> fragmentShader;  // empty: depth only (no fragment stage)
  VertexLayout vertexLayout;
  std::vector<VkFormat> colorFormats;
  Blend blend = Blend::None;  // applied to every colour attachment
  VkFormat depthFormat = VK_FORMAT_UNDEFINED;
  bool depthTest = false;
  bool depthWrite = false;
  VkCompareOp depthCompare = VK_COMPARE_OP_LESS;
  bool depthClamp = false;  // requires the depthClamp feature
  VkCullModeFlags cullMode = VK_CULL_MODE_NONE;
  bool dynamicCullMode = false;  // set per draw with vkCmdSetCullMode (core in Vulkan 1.3)
  const VkSpecializationInfo* fragmentSpecialization = nullptr;  // may be null
};

VkShaderModule createShaderModule(VkDevice device, std::span<const uint32_t> spirv);

// Viewport and scissor are dynamic; everything else is baked from `desc`.
VkPipeline createGraphicsPipeline(VkDevice device, VkPipelineLayout layout,
                                  const GraphicsPipelineDesc& desc);

// `specialization` may be null.
VkPipeline createComputePipeline(VkDevice device, VkPipelineLayout layout,
                                 std::span<const uint32_t> shader,
                                 const VkSpecializationInfo* specialization = nullptr);

// A diagnostic (ContextOptions::pipelineStatistics, `--tune pipeline-stats=on`, where the device
// has VK_KHR_pipeline_executable_properties; createContext decides): compute pipelines made after
// this print the driver's statistics of their code (registers, spills, ...) to stderr, with the
// SPIR-V's size and specialisation to tell them apart.
void capturePipelineStatistics(bool on);

VkDescriptorSetLayout createDescriptorSetLayout(
    VkDevice device, std::span<const VkDescriptorSetLayoutBinding> bindings);

}  // namespace myriad::gpu
