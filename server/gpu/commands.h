// Command recording helpers: barriers (synchronization2), one command buffer with its fence, and
// GPU timestamps per pass.
#pragma once

#include <span>
#include <string>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "gpu/resources.h"

namespace myriad::gpu {

// One layout/access transition of an image's mip levels [firstLevel, firstLevel + levels) (by
// default its only level). Stages and accesses are the exact producer and consumer of the
// dependency; callers batch them with `barrier`.
struct ImageTransition {
  const Image* image;
  VkPipelineStageFlags2 srcStage;
  VkAccessFlags2 srcAccess;
  VkPipelineStageFlags2 dstStage;
  VkAccessFlags2 dstAccess;
  VkImageLayout oldLayout;
  VkImageLayout newLayout;
  uint32_t firstLevel = 0;
  uint32_t levels = 1;
};

void barrier(VkCommandBuffer cmd, std::span<const ImageTransition> transitions);

// A buffer dependency (e.g. a copy into the readback buffer, then the host reads it).
void bufferBarrier(VkCommandBuffer cmd, const Buffer& buffer, VkPipelineStageFlags2 srcStage,
                   VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage,
                   VkAccessFlags2 dstAccess);

// A global memory dependency: every buffer written by `src` becomes visible to `dst`. Used
// between compute passes that hand several buffers to each other.
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess);

// Workgroups needed to cover `items` with groups of `groupSize`.
inline uint32_t groupCount(uint32_t items, uint32_t groupSize) {
  return (items + groupSize - 1) / groupSize;
}

// Workgroups [first, first + count) of a groupsX x groupsY grid, numbered row by row, dispatched
// with their own workgroup ids (vkCmdDispatchBase: at most three dispatches, a part row, whole
// rows, a part row). The bound compute pipeline must allow a base (createComputePipeline's do).
// A pass over pixels recorded this way in several submissions equals the pass recorded whole.
void dispatchGroupRange(VkCommandBuffer cmd, uint32_t groupsX, uint32_t groupsY, uint32_t first,
                        uint32_t count);

// The workgroups of a groupsX x groupsY pass over pixels in an order that spreads any run of them
// over the whole image: blocks of `block` workgroups along a row, the blocks visited with a
// stride coprime with their count (about 0.618 of it). A split frame shades ranges of this order,
// so that the cost of the first ranges predicts the rest (in raster order a run of sky tiles
// costs a thousandth of a run of long light lists below it). Any set of ranges covering
// [0, groups()) dispatches every workgroup exactly once, as the pass recorded whole does.
class ScatteredGroups {
 public:
  ScatteredGroups(uint32_t groupsX, uint32_t groupsY, uint32_t block);
  uint32_t groups() const { return groupsX_ * groupsY_; }
  // Every workgroup (x, y), in the order.
  std::vector<std::pair<uint32_t, uint32_t>> order() const;
  // Dispatches workgroups [first, first + count) of the order (one dispatch per block touched).
  void dispatch(VkCommandBuffer cmd, uint32_t first, uint32_t count) const;

 private:
  uint32_t groupsX_;
  uint32_t groupsY_;
  uint32_t block_;
  uint32_t blocksPerRow_;
  uint32_t blocks_;
  uint32_t stride_;  // coprime with blocks_
  // The block at position `b` of the order: its first workgroup and its length.
  void blockAt(uint32_t b, uint32_t& x, uint32_t& y, uint32_t& length) const;
};

// A primary command buffer, re-recorded every frame, and the fence its submission signals.
struct CommandRecorder {
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
};

CommandRecorder createCommandRecorder(Context& context);
void destroyCommandRecorder(Context& context, CommandRecorder& recorder);
VkCommandBuffer beginCommands(Context& context, CommandRecorder& recorder);
// Ends, submits on the context's queue and waits for completion.
void submitAndWait(Context& context, CommandRecorder& recorder);
// Ends and submits on the context's queue without waiting: the recorder's command buffer stays
// pending (neither re-recorded nor its resources touched by the host) until waitFor() returns.
void submit(Context& context, CommandRecorder& recorder);
// Waits for the recorder's last submission (submit or submitAndWait) to complete.
void waitFor(Context& context, CommandRecorder& recorder);

// Timestamps between passes: mark(i) after pass i-1 ends; pass i takes t[i+1] - t[i].
class PassTimer {
 public:
  PassTimer(Context& context, uint32_t maxPasses);
  ~PassTimer();
  PassTimer(const PassTimer&) = delete;
  PassTimer& operator=(const PassTimer&) = delete;

  void reset(VkCommandBuffer cmd);
  // Marks the end of everything recorded so far and the start of pass `name`.
  void beginPass(VkCommandBuffer cmd, const char* name);
  void end(VkCommandBuffer cmd);
  // After the submission completed: (name, milliseconds) per pass; empty without timestamps.
  std::vector<std::pair<std::string, double>> results();
  // The first and last timestamps results() read (raw ticks, the queue's time base; 0 before).
  uint64_t firstTick() const { return firstTick_; }
  uint64_t lastTick() const { return lastTick_; }
  // Frame boundaries only: beginPass writes the first timestamp and then none, so results() has
  // one pass, "frame", for the whole submission: the first written at the top of the pipe (it
  // waits for nothing), the last at ALL_COMMANDS. A timestamp at ALL_COMMANDS between passes (or
  // at a frame's start) may hold later work back until everything before it drained.
  void setFrameOnly(bool frameOnly) { frameOnly_ = frameOnly; }
  // No timestamps at all (results() is empty): whether the frame's last timestamp (ALL_COMMANDS)
  // holds the next frame back.
  void setOff(bool off) { off_ = off; }

 private:
  Context* context_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  uint32_t capacity_;
  std::vector<std::string> names_;
  uint32_t written_ = 0;
  bool frameOnly_ = false;
  bool off_ = false;
  uint64_t firstTick_ = 0;
  uint64_t lastTick_ = 0;
};

}  // namespace myriad::gpu
