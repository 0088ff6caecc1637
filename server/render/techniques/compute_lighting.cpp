#include "render/techniques/compute_lighting.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

// The counters are 32 bytes; a default 64 MiB block would be almost all waste.
constexpr VkDeviceSize kCountersBlockSize = 64ull << 10;

constexpr uint32_t kCullingBindings = 6;  // MYRIAD_BINDING_CLUSTER_RANGES .. _CLUSTER_PAIRS

}  // namespace

void requireWorkgroup(const gpu::Context& context, uint32_t invocations, uint32_t sizeX) {
  const gpu::DeviceInfo& limits = context.info;
  if (limits.maxComputeWorkGroupInvocations < invocations ||
      limits.maxComputeWorkGroupSizeX < sizeX) {
    throw std::runtime_error(limits.name + " runs compute workgroups of at most " +
                             std::to_string(limits.maxComputeWorkGroupInvocations) +
                             " invocations; Myriad's light culling needs " +
                             std::to_string(invocations) + ".");
  }
}

CullingSet::CullingSet(gpu::Context& context, const Pipelines& pipelines)
    : device_(context.device), layout_(pipelines.layout) {
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kCullingBindings};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(device_, &poolInfo, nullptr, &pool_));
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = pool_;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &pipelines.cullingSetLayout;
  VkResult result = vkAllocateDescriptorSets(device_, &alloc, &set_);
  if (result != VK_SUCCESS) {
    vkDestroyDescriptorPool(device_, pool_, nullptr);
    VK_CHECK(result);
  }
}

CullingSet::~CullingSet() {
  vkDestroyDescriptorPool(device_, pool_, nullptr);  // frees the set
}

void CullingSet::write(std::span<const Binding> bindings) {
  std::vector<VkDescriptorBufferInfo> infos(bindings.size());
  std::vector<VkWriteDescriptorSet> writes(bindings.size());
  for (size_t i = 0; i < bindings.size(); ++i) {
    infos[i] = {bindings[i].buffer->buffer, 0, VK_WHOLE_SIZE};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set_;
    writes[i].dstBinding = bindings[i].binding;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(device_, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

void CullingSet::bind(VkCommandBuffer cmd) const {
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, MYRIAD_SET_CULLING, 1,
                          &set_, 0, nullptr);
}

void CullingSet::bindGraphics(VkCommandBuffer cmd) const {
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, MYRIAD_SET_CULLING, 1,
                          &set_, 0, nullptr);
}

CullingCounters::CullingCounters(gpu::Context& context) : arena(context, kCountersBlockSize) {
  stats = arena.createBuffer(sizeof(CullingStats),
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                             gpu::MemoryUse::Readback);
}

void CullingCounters::reset(VkCommandBuffer cmd) const {
  vkCmdFillBuffer(cmd, stats.buffer, 0, VK_WHOLE_SIZE, 0);
}

void CullingCounters::makeHostVisible(VkCommandBuffer cmd) const {
  gpu::bufferBarrier(cmd, stats, kComputeStage, kStorageWrite,
                     VK_PIPELINE_STAGE_2_HOST_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_HOST_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
}

void CullingCounters::read(const void* copy, CullingReport& report) {
  CullingStats counters;
  std::memcpy(&counters, copy, sizeof(counters));
  report.tilesOverflowed = counters.overflow.x;
  report.tileLightsDropped = counters.overflow.y;
  report.clusterLightsDropped = counters.overflow.z;
  report.listEntries = counters.totals.x;
  report.activeClusters = counters.totals.y;
  report.mostLightsInList = counters.totals.z;
}

void prepareLightingTargets(VkCommandBuffer cmd, const FrameTargets& t) {
  const gpu::ImageTransition transitions[] = {
      {&t.hdr, kComputeStage, VK_ACCESS_2_NONE, kComputeStage,
       kStorageWrite, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
      {&t.lightCount, kComputeStage, VK_ACCESS_2_NONE, kComputeStage,
       kStorageWrite, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
  };
  gpu::barrier(cmd, transitions);
}

void dispatchPixels(VkCommandBuffer cmd, VkPipeline pipeline, VkExtent2D extent, uint32_t group) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdDispatch(cmd, gpu::groupCount(extent.width, group), gpu::groupCount(extent.height, group), 1);
}

gpu::ScatteredGroups scatteredTiles(VkExtent2D extent, uint32_t group) {
  const uint32_t x = gpu::groupCount(extent.width, group);
  const uint32_t y = gpu::groupCount(extent.height, group);
  constexpr uint32_t kMostBlocks = 4096;
  return gpu::ScatteredGroups(x, y, std::max(2u, gpu::groupCount(x * y, kMostBlocks)));
}

}  // namespace myriad::render
