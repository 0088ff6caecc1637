#include "render/compute_passes.h"

#include "gpu/commands.h"
#include "render/gpu_types.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::groupCount;

constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkAccessFlags2 kStorageWrite = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
constexpr VkAccessFlags2 kStorageReadWrite =
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;

// Lighting targets are rewritten each frame; the previous frame last sampled them (tonemap).
void prepareLightingTargets(VkCommandBuffer cmd, const FrameTargets& t) {
  const gpu::ImageTransition transitions[] = {
      {&t.hdr, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE, kCompute, kStorageWrite,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
      {&t.lightCount, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE, kCompute,
       kStorageWrite, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
  };
  gpu::barrier(cmd, transitions);
}

// vkCmdFillBuffer is a transfer command whose exact stage (CLEAR or COPY) the specification and
// the validation layers have disagreed on; ALL_TRANSFER covers both at no cost here.
constexpr VkPipelineStageFlags2 kFillStage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;

void resetStats(VkCommandBuffer cmd, const LightGrid& grid) {
  vkCmdFillBuffer(cmd, grid.stats.buffer, 0, VK_WHOLE_SIZE, 0);
}

void dispatchPixels(VkCommandBuffer cmd, VkPipeline pipeline, VkExtent2D extent, uint32_t group) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdDispatch(cmd, groupCount(extent.width, group), groupCount(extent.height, group), 1);
}

}  // namespace

void recordAnimateLights(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene) {
  if (scene.lightCount == 0) return;
  // The previous frame's readers of the lights (vertex and compute shaders) finish first.
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCompute,
                     VK_ACCESS_2_NONE, kCompute, kStorageWrite);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.animateLights);
  vkCmdDispatch(cmd, groupCount(scene.lightCount, MYRIAD_LIGHTS_PER_GROUP), 1, 1);
  gpu::memoryBarrier(cmd, kCompute, kStorageWrite,
                     VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCompute,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

void recordRestoreLights(VkCommandBuffer cmd, const SceneBuffers& scene) {
  if (scene.lightCount == 0) return;
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCompute,
                     VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  VkBufferCopy region{0, 0, VkDeviceSize(scene.lightCount) * sizeof(GpuPointLight)};
  vkCmdCopyBuffer(cmd, scene.lightOrigins.buffer, scene.lights.buffer, 1, &region);
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCompute,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

void recordTiledLighting(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                         const LightGrid& grid) {
  resetStats(cmd, grid);
  gpu::memoryBarrier(cmd, kFillStage, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                     kStorageReadWrite);
  prepareLightingTargets(cmd, t);
  dispatchPixels(cmd, p.tiledLighting, t.extent, MYRIAD_TILE_SIZE);
}

void recordClusteredLighting(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                             const LightGrid& grid, const SceneBuffers& scene) {
  // Every cluster starts inactive; the stats start at zero.
  vkCmdFillBuffer(cmd, grid.cursors.buffer, 0, VK_WHOLE_SIZE, MYRIAD_CLUSTER_INACTIVE);
  resetStats(cmd, grid);
  gpu::memoryBarrier(cmd, kFillStage, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                     kStorageReadWrite);

  // 1. Mark clusters holding visible geometry.
  dispatchPixels(cmd, p.clusterMark, t.extent, MYRIAD_PIXEL_GROUP);
  gpu::memoryBarrier(cmd, kCompute, kStorageWrite, kCompute, kStorageReadWrite);
  uint32_t lightGroups = groupCount(scene.lightCount, MYRIAD_LIGHTS_PER_GROUP);
  if (lightGroups > 0) {
    // 2. Count each active cluster's lights.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.clusterCount);
    vkCmdDispatch(cmd, lightGroups, 1, 1);
    gpu::memoryBarrier(cmd, kCompute, kStorageWrite, kCompute, kStorageReadWrite);
  }
  // 3. Prefix sum: list offsets, capacity cuts, counters.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.clusterScan);
  vkCmdDispatch(cmd, 1, 1, 1);
  gpu::memoryBarrier(cmd, kCompute, kStorageWrite, kCompute, kStorageReadWrite);
  if (lightGroups > 0) {
    // 4. Fill the lists.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.clusterAssign);
    vkCmdDispatch(cmd, lightGroups, 1, 1);
    gpu::memoryBarrier(cmd, kCompute, kStorageWrite, kCompute, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  }
  // 5. Shade every pixel from its cluster's list.
  prepareLightingTargets(cmd, t);
  dispatchPixels(cmd, p.clusteredLighting, t.extent, MYRIAD_PIXEL_GROUP);
}

}  // namespace myriad::render
