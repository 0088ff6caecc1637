#include "render/compute_passes.h"

#include "gpu/commands.h"
#include "render/gpu_types.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::groupCount;

constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkAccessFlags2 kStorageWrite = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;

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

}  // namespace myriad::render
