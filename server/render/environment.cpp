#include "render/environment.h"

#include <array>
#include <cstring>
#include <stdexcept>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::groupCount;
using gpu_types::EnvironmentParams;

constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkPipelineStageFlags2 kShaders =
    VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkAccessFlags2 kWrite = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
constexpr VkAccessFlags2 kRead = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;

constexpr VkDeviceSize kSourceBytes = VkDeviceSize(MYRIAD_ENV_SOURCE_TEXELS) * 16;
constexpr VkDeviceSize kLevel0Bytes =
    VkDeviceSize(MYRIAD_ENV_SOURCE_WIDTH) * MYRIAD_ENV_SOURCE_HEIGHT * 16;
constexpr uint32_t kSpecularTexels =
    MYRIAD_ENV_SPECULAR_WIDTH * MYRIAD_ENV_SPECULAR_HEIGHT * MYRIAD_ENV_SPECULAR_LEVELS;
constexpr VkDeviceSize kLightingBytes = VkDeviceSize(MYRIAD_ENV_HEADER + kSpecularTexels) * 16;
constexpr VkDeviceSize kLutBytes = VkDeviceSize(MYRIAD_BRDF_LUT_SIZE) * MYRIAD_BRDF_LUT_SIZE * 16;

static_assert(scene::kEnvironmentWidth == MYRIAD_ENV_SOURCE_WIDTH);
static_assert(scene::kEnvironmentHeight == MYRIAD_ENV_SOURCE_HEIGHT);

void dispatch(VkCommandBuffer cmd, VkPipeline pipeline, VkPipelineLayout layout,
              const EnvironmentParams& params, uint32_t items) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(params), &params);
  vkCmdDispatch(cmd, groupCount(items, MYRIAD_ENV_GROUP), 1, 1);
}

void computeToCompute(VkCommandBuffer cmd) {
  gpu::memoryBarrier(cmd, kCompute, kWrite, kCompute, kRead | kWrite);
}

}  // namespace

SceneEnvironment::SceneEnvironment(gpu::Context& c) : context(c), arena(c, 2ull << 20) {
  source = arena.createBuffer(kSourceBytes,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              gpu::MemoryUse::DeviceLocal);
  lighting = arena.createBuffer(kLightingBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                gpu::MemoryUse::DeviceLocal);
}

void SceneEnvironment::setImage(std::shared_ptr<const scene::EnvironmentImage> next) {
  if (!next || next->rgb.size() != size_t(MYRIAD_ENV_SOURCE_WIDTH) * MYRIAD_ENV_SOURCE_HEIGHT * 3) {
    throw std::invalid_argument("an environment image must be 256x128 RGB floats");
  }
  if (!stagingArena) {
    stagingArena = std::make_unique<gpu::Arena>(context, kLevel0Bytes);
    staging = stagingArena->createBuffer(kLevel0Bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                         gpu::MemoryUse::Upload);
  }
  // Frames are synchronous: no GPU work reads the staging buffer now.
  float* out = static_cast<float*>(staging.mapped);
  const size_t texels = size_t(MYRIAD_ENV_SOURCE_WIDTH) * MYRIAD_ENV_SOURCE_HEIGHT;
  for (size_t i = 0; i < texels; ++i) {
    out[i * 4 + 0] = next->rgb[i * 3 + 0];
    out[i * 4 + 1] = next->rgb[i * 3 + 1];
    out[i * 4 + 2] = next->rgb[i * 3 + 2];
    out[i * 4 + 3] = 1.0f;
  }
  image = std::move(next);
  ++imageVersion;
}

EnvironmentPasses::EnvironmentPasses(gpu::Context& context, gpu::CommandRecorder& recorder)
    : context_(context), arena_(context, 64ull << 10) {
  VkDevice device = context.device;
  std::array<VkDescriptorSetLayoutBinding, 3> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(device, bindings);
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(EnvironmentParams)};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &setLayout_;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &layout_));
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &pool_));
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = pool_;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &setLayout_;
  VK_CHECK(vkAllocateDescriptorSets(device, &alloc, &set_));
  sky_ = gpu::createComputePipeline(device, layout_, spirv::env_sky_comp);
  downsample_ = gpu::createComputePipeline(device, layout_, spirv::env_downsample_comp);
  irradiance_ = gpu::createComputePipeline(device, layout_, spirv::env_irradiance_comp);
  prefilter_ = gpu::createComputePipeline(device, layout_, spirv::env_prefilter_comp);
  lut_ = gpu::createComputePipeline(device, layout_, spirv::brdf_lut_comp);

  brdfLut_ = arena_.createBuffer(kLutBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 gpu::MemoryUse::DeviceLocal);
  // The table pass touches only the table; the other bindings need some valid buffer.
  writeSet(brdfLut_, brdfLut_);
  VkCommandBuffer cmd = gpu::beginCommands(context, recorder);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, 0, nullptr);
  dispatch(cmd, lut_, layout_, EnvironmentParams{}, MYRIAD_BRDF_LUT_SIZE * MYRIAD_BRDF_LUT_SIZE);
  gpu::memoryBarrier(cmd, kCompute, kWrite, kShaders, kRead);
  gpu::submitAndWait(context, recorder);
}

EnvironmentPasses::~EnvironmentPasses() {
  VkDevice device = context_.device;
  for (VkPipeline p : {sky_, downsample_, irradiance_, prefilter_, lut_}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  if (pool_) vkDestroyDescriptorPool(device, pool_, nullptr);
  if (layout_) vkDestroyPipelineLayout(device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device, setLayout_, nullptr);
}

void EnvironmentPasses::writeSet(const gpu::Buffer& source, const gpu::Buffer& lighting) {
  VkDescriptorBufferInfo infos[3] = {{source.buffer, 0, VK_WHOLE_SIZE},
                                     {lighting.buffer, 0, VK_WHOLE_SIZE},
                                     {brdfLut_.buffer, 0, VK_WHOLE_SIZE}};
  VkWriteDescriptorSet writes[3];
  for (uint32_t i = 0; i < 3; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set_;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(context_.device, 3, writes, 0, nullptr);
}

SceneEnvironment::Inputs EnvironmentPasses::inputsFor(const FrameSettings& s,
                                                      const SceneEnvironment& env) {
  SceneEnvironment::Inputs in;
  in.mode = s.environment.mode;
  if (in.mode == EnvironmentMode::Sky) {
    in.toSun = -glm::normalize(s.sun.direction);
    in.sunColor = s.sun.color;
  } else if (in.mode == EnvironmentMode::Hdr) {
    if (!env.hasImage()) {
      throw std::invalid_argument("the environment is \"hdr\" but the scene has no .hdr image");
    }
    in.imageVersion = env.imageVersion;
  }
  return in;
}

void EnvironmentPasses::record(VkCommandBuffer cmd, SceneEnvironment& env,
                               const SceneEnvironment::Inputs& in) {
  // Nothing rewrites the set while a submission uses it: frames are synchronous.
  writeSet(env.source, env.lighting);
  // Earlier frames' shaders read these maps; this rebuild overwrites them.
  gpu::memoryBarrier(cmd, kShaders | VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                     kCompute | VK_PIPELINE_STAGE_2_COPY_BIT, kWrite | VK_ACCESS_2_TRANSFER_WRITE_BIT);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, 0, nullptr);
  EnvironmentParams params{};
  params.sunDirection = glm::vec4(in.toSun, 0.0f);
  params.sunColor = glm::vec4(in.sunColor, 0.0f);
  params.step = glm::uvec4(0, static_cast<uint32_t>(in.mode), 0, 0);
  if (in.mode == EnvironmentMode::Hdr) {
    VkBufferCopy region{0, 0, kLevel0Bytes};
    vkCmdCopyBuffer(cmd, env.staging.buffer, env.source.buffer, 1, &region);
    gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                       kRead | kWrite);
  } else {
    dispatch(cmd, sky_, layout_, params, MYRIAD_ENV_SOURCE_WIDTH * MYRIAD_ENV_SOURCE_HEIGHT);
    computeToCompute(cmd);
  }
  for (uint32_t level = 1; level < MYRIAD_ENV_SOURCE_LEVELS; ++level) {
    params.step.x = level;
    dispatch(cmd, downsample_, layout_, params,
             (MYRIAD_ENV_SOURCE_WIDTH >> level) * (MYRIAD_ENV_SOURCE_HEIGHT >> level));
    computeToCompute(cmd);
  }
  dispatch(cmd, irradiance_, layout_, params, MYRIAD_ENV_HEADER);
  dispatch(cmd, prefilter_, layout_, params, kSpecularTexels);
  gpu::memoryBarrier(cmd, kCompute, kWrite, kShaders, kRead);
  env.built = in;
  ++env.rebuilds;
}

}  // namespace myriad::render
