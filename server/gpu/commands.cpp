#include "gpu/commands.h"

#include <algorithm>
#include <numeric>

#include "gpu/vk_check.h"

namespace myriad::gpu {

void barrier(VkCommandBuffer cmd, std::span<const ImageTransition> transitions) {
  std::vector<VkImageMemoryBarrier2> barriers;
  barriers.reserve(transitions.size());
  for (const ImageTransition& t : transitions) {
    VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    b.srcStageMask = t.srcStage;
    b.srcAccessMask = t.srcAccess;
    b.dstStageMask = t.dstStage;
    b.dstAccessMask = t.dstAccess;
    b.oldLayout = t.oldLayout;
    b.newLayout = t.newLayout;
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = t.image->image;
    b.subresourceRange = {t.image->aspect, t.firstLevel, t.levels, 0, 1};
    barriers.push_back(b);
  }
  VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(barriers.size());
  dependency.pImageMemoryBarriers = barriers.data();
  vkCmdPipelineBarrier2(cmd, &dependency);
}

void dispatchGroupRange(VkCommandBuffer cmd, uint32_t groupsX, uint32_t groupsY, uint32_t first,
                        uint32_t count) {
  const uint64_t total = uint64_t(groupsX) * groupsY;
  if (groupsX == 0 || first >= total) return;
  const uint32_t end = static_cast<uint32_t>(std::min<uint64_t>(uint64_t(first) + count, total));
  uint32_t at = first;
  if (at % groupsX != 0) {  // the rest of a row begun
    const uint32_t row = at / groupsX;
    const uint32_t x = at % groupsX;
    const uint32_t n = std::min(groupsX - x, end - at);
    vkCmdDispatchBase(cmd, x, row, 0, n, 1, 1);
    at += n;
  }
  if (const uint32_t rows = (end - at) / groupsX; rows > 0) {  // whole rows
    vkCmdDispatchBase(cmd, 0, at / groupsX, 0, groupsX, rows, 1);
    at += rows * groupsX;
  }
  if (at < end) vkCmdDispatchBase(cmd, 0, at / groupsX, 0, end - at, 1, 1);  // a row begun
}

void bufferBarrier(VkCommandBuffer cmd, const Buffer& buffer, VkPipelineStageFlags2 srcStage,
                   VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage,
                   VkAccessFlags2 dstAccess) {
  VkBufferMemoryBarrier2 b{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2};
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.buffer = buffer.buffer;
  b.offset = 0;
  b.size = VK_WHOLE_SIZE;
  VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dependency.bufferMemoryBarrierCount = 1;
  dependency.pBufferMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkMemoryBarrier2 b{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dependency.memoryBarrierCount = 1;
  dependency.pMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

ScatteredGroups::ScatteredGroups(uint32_t groupsX, uint32_t groupsY, uint32_t block)
    : groupsX_(groupsX), groupsY_(groupsY), block_(std::max(1u, std::min(block, std::max(groupsX, 1u)))) {
  blocksPerRow_ = (groupsX_ + block_ - 1) / block_;
  blocks_ = blocksPerRow_ * groupsY_;
  stride_ = 1;
  if (blocks_ > 2) {
    stride_ = std::max(1u, uint32_t(double(blocks_) * 0.6180339887));
    while (std::gcd(stride_, blocks_) != 1) ++stride_;
  }
}

void ScatteredGroups::blockAt(uint32_t b, uint32_t& x, uint32_t& y, uint32_t& length) const {
  const uint32_t block = uint32_t(uint64_t(b) * stride_ % blocks_);
  y = block / blocksPerRow_;
  x = block % blocksPerRow_ * block_;
  length = std::min(block_, groupsX_ - x);
}

std::vector<std::pair<uint32_t, uint32_t>> ScatteredGroups::order() const {
  std::vector<std::pair<uint32_t, uint32_t>> all;
  all.reserve(groups());
  for (uint32_t b = 0; b < blocks_; ++b) {
    uint32_t x = 0;
    uint32_t y = 0;
    uint32_t length = 0;
    blockAt(b, x, y, length);
    for (uint32_t i = 0; i < length; ++i) all.emplace_back(x + i, y);
  }
  return all;
}

void ScatteredGroups::dispatch(VkCommandBuffer cmd, uint32_t first, uint32_t count) const {
  // Find the block holding `first`, then one dispatch per block (or part of one) in the range.
  uint32_t b = 0;
  uint32_t x = 0;
  uint32_t y = 0;
  uint32_t length = 0;
  uint32_t skip = first;
  for (; b < blocks_; ++b) {
    blockAt(b, x, y, length);
    if (skip < length) break;
    skip -= length;
  }
  for (; b < blocks_ && count > 0; ++b) {
    if (skip == 0) blockAt(b, x, y, length);
    const uint32_t n = std::min(length - skip, count);
    vkCmdDispatchBase(cmd, x + skip, y, 0, n, 1, 1);
    count -= n;
    skip = 0;
  }
}

CommandRecorder createCommandRecorder(Context& context) {
  CommandRecorder r;
  VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  poolInfo.queueFamilyIndex = context.queueFamily;
  VK_CHECK(vkCreateCommandPool(context.device, &poolInfo, nullptr, &r.pool));
  VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = r.pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VK_CHECK(vkAllocateCommandBuffers(context.device, &alloc, &r.cmd));
  VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(context.device, &fenceInfo, nullptr, &r.fence));
  return r;
}

void destroyCommandRecorder(Context& context, CommandRecorder& r) {
  if (r.fence) vkDestroyFence(context.device, r.fence, nullptr);
  if (r.pool) vkDestroyCommandPool(context.device, r.pool, nullptr);  // frees r.cmd
  r = {};
}

VkCommandBuffer beginCommands(Context&, CommandRecorder& r) {
  VK_CHECK(vkResetCommandBuffer(r.cmd, 0));
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(r.cmd, &begin));
  return r.cmd;
}

void submitAndWait(Context& context, CommandRecorder& r) {
  submit(context, r);
  waitFor(context, r);
}

void submit(Context& context, CommandRecorder& r) {
  VK_CHECK(vkEndCommandBuffer(r.cmd));
  VkCommandBufferSubmitInfo cmdInfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cmdInfo.commandBuffer = r.cmd;
  VkSubmitInfo2 info{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  info.commandBufferInfoCount = 1;
  info.pCommandBufferInfos = &cmdInfo;
  VK_CHECK(vkResetFences(context.device, 1, &r.fence));
  VK_CHECK(vkQueueSubmit2(context.queue, 1, &info, r.fence));
}

void waitFor(Context& context, CommandRecorder& r) {
  VK_CHECK(vkWaitForFences(context.device, 1, &r.fence, VK_TRUE, UINT64_MAX));
}

PassTimer::PassTimer(Context& context, uint32_t maxPasses)
    : context_(&context), capacity_(maxPasses + 1) {
  if (!context.info.timestampsSupported) return;
  VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = capacity_;
  VK_CHECK(vkCreateQueryPool(context.device, &info, nullptr, &pool_));
}

PassTimer::~PassTimer() {
  if (pool_) vkDestroyQueryPool(context_->device, pool_, nullptr);
}

void PassTimer::reset(VkCommandBuffer cmd) {
  names_.clear();
  written_ = 0;
  if (pool_ && !off_) vkCmdResetQueryPool(cmd, pool_, 0, capacity_);
}

// Timestamps wait for all earlier work (ALL_COMMANDS): a pass's time is then the time between the
// end of the previous pass and its own end, which is what a per-pass budget needs. This is a
// timestamp stage, not a barrier; it orders nothing.
void PassTimer::beginPass(VkCommandBuffer cmd, const char* name) {
  if (!pool_ || off_ || written_ + 1 >= capacity_) return;
  if (frameOnly_ && written_ > 0) return;
  // The pass that runs already, recorded on (a technique's step recorded in ranges): no mark.
  if (!names_.empty() && names_.back() == name) return;
  // Frame boundaries only: the first timestamp at the top of the pipe waits for nothing, so the
  // frame's work may start while earlier frames' still runs (--overlap-frames).
  vkCmdWriteTimestamp2(cmd,
                       frameOnly_ ? VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT
                                  : VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                       pool_, written_++);
  names_.emplace_back(frameOnly_ ? "frame" : name);
}

void PassTimer::end(VkCommandBuffer cmd) {
  if (!pool_ || written_ == 0) return;
  vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, written_++);
}

std::vector<std::pair<std::string, double>> PassTimer::results() {
  std::vector<std::pair<std::string, double>> out;
  if (!pool_ || written_ < 2) return out;
  std::vector<uint64_t> ticks(written_);
  VK_CHECK(vkGetQueryPoolResults(context_->device, pool_, 0, written_, ticks.size() * sizeof(uint64_t),
                                 ticks.data(), sizeof(uint64_t),
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  firstTick_ = ticks.front();
  lastTick_ = ticks.back();
  double msPerTick = context_->info.timestampPeriodNs * 1e-6;
  for (uint32_t i = 0; i + 1 < written_ && i < names_.size(); ++i) {
    out.emplace_back(names_[i], static_cast<double>(ticks[i + 1] - ticks[i]) * msPerTick);
  }
  return out;
}

}  // namespace myriad::gpu
