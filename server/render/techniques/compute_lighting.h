// What the compute techniques (tiled, clustered) share: their own descriptor set 2 (light
// culling), the culling counters the shaders write and the host reads back, and the steps around
// a compute shading dispatch.
#pragma once

#include <cstdint>
#include <span>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "render/frame_targets.h"
#include "render/passes.h"

namespace myriad::render {

inline constexpr VkPipelineStageFlags2 kComputeStage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
inline constexpr VkAccessFlags2 kStorageWrite = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
inline constexpr VkAccessFlags2 kStorageReadWrite =
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
// vkCmdFillBuffer is a transfer command whose exact stage (CLEAR or COPY) the specification and
// the validation layers have disagreed on; ALL_TRANSFER covers both at no cost here.
inline constexpr VkPipelineStageFlags2 kFillStage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;

// Throws std::runtime_error (one sentence) when the device cannot run a workgroup of
// `invocations` invocations, `sizeX` wide.
void requireWorkgroup(const gpu::Context& context, uint32_t invocations, uint32_t sizeX);

// A technique's own descriptor set of the shared set-2 layout (MYRIAD_SET_CULLING). Only the
// bindings its shaders use need writing.
class CullingSet {
 public:
  CullingSet(gpu::Context& context, const Pipelines& pipelines);
  ~CullingSet();
  CullingSet(const CullingSet&) = delete;
  CullingSet& operator=(const CullingSet&) = delete;

  struct Binding {
    uint32_t binding;  // MYRIAD_BINDING_CLUSTER_RANGES ...
    const gpu::Buffer* buffer;
  };
  void write(std::span<const Binding> bindings);
  // Binds the set for compute dispatches (set 2; sets 0 and 1 stay as the frame bound them).
  void bind(VkCommandBuffer cmd) const;
  // The same at the graphics bind point (fragment shaders reading or marking clusters).
  void bindGraphics(VkCommandBuffer cmd) const;

 private:
  VkDevice device_;
  VkPipelineLayout layout_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

// The CullingStats buffer, host-visible: zeroed on the GPU each frame, read after it.
struct CullingCounters {
  explicit CullingCounters(gpu::Context& context);

  gpu::Arena arena;
  gpu::Buffer stats;

  // Zeroes the counters (a transfer fill; followed by `kFillStage` -> compute barriers by the
  // caller, batched with its own fills).
  void reset(VkCommandBuffer cmd) const;
  // After the last compute write: the host may read the counters once the frame's fence signals,
  // and a copy (the renderer's, into the frame slot's own buffer) may read them.
  void makeHostVisible(VkCommandBuffer cmd) const;
  // A copy of `stats` (sizeof(CullingStats) bytes, after the frame) into `report`.
  static void read(const void* counters, CullingReport& report);
};

// Lighting targets are rewritten each frame; the previous frame last sampled them (the final or
// views pass, compute).
// UNDEFINED -> GENERAL for compute storage writes.
void prepareLightingTargets(VkCommandBuffer cmd, const FrameTargets& t);

// Binds `pipeline` and dispatches one workgroup per `group` x `group` pixels of `extent`.
void dispatchPixels(VkCommandBuffer cmd, VkPipeline pipeline, VkExtent2D extent, uint32_t group);

// The order a split frame shades the tiles (`group` x `group` pixels) of `extent` in
// (gpu::ScatteredGroups): blocks of at least two tiles (a CPU device runs a dispatch's
// workgroups on its threads: one tile a dispatch would leave all but one of them idle), at most
// 4096 blocks (one dispatch each).
gpu::ScatteredGroups scatteredTiles(VkExtent2D extent, uint32_t group);

}  // namespace myriad::render
