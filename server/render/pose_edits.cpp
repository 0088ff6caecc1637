// A pose applied to a scene on the GPU (SceneBuffers::applyPose, applyPrevious): node transforms
// through the instance update path, joint matrices and morph weights uploaded, the bounds the
// posed meshes reach.
#include <algorithm>
#include <cstring>
#include <utility>

#include "render/gpu_types.h"
#include "render/scene_buffers.h"
#include "render/skinning.h"

namespace myriad::render {

namespace {

bool samePose(const ScenePose& a, const ScenePose& b) {
  if (a.transforms.size() != b.transforms.size() || a.poses.size() != b.poses.size()) return false;
  for (size_t i = 0; i < a.transforms.size(); ++i) {
    if (a.transforms[i].index != b.transforms[i].index ||
        a.transforms[i].transform != b.transforms[i].transform) {
      return false;
    }
  }
  for (size_t i = 0; i < a.poses.size(); ++i) {
    if (a.poses[i].instance != b.poses[i].instance || a.poses[i].joints != b.poses[i].joints ||
        a.poses[i].morphWeights != b.poses[i].morphWeights) {
      return false;
    }
  }
  return true;
}

// The box around a sphere (xyz centre, w radius).
void extendBySphere(scene::Bounds& bounds, glm::vec3 centre, float radius) {
  bounds.extend(centre - glm::vec3(radius));
  bounds.extend(centre + glm::vec3(radius));
}

}  // namespace

void writeBuffers(gpu::Context& context, gpu::CommandRecorder& recorder,
                  const std::vector<BufferCopy>& copies, const std::vector<BufferWrite>& writes) {
  VkDeviceSize total = 0;
  for (const BufferWrite& w : writes) total += w.size;
  if (copies.empty() && total == 0) return;
  gpu::Arena staging(context, std::max<VkDeviceSize>(total, 16));
  const gpu::Buffer buffer = staging.createBuffer(std::max<VkDeviceSize>(total, 16),
                                                  VK_BUFFER_USAGE_TRANSFER_SRC_BIT, gpu::MemoryUse::Upload);
  VkCommandBuffer cmd = gpu::beginCommands(context, recorder);
  // Earlier frames read these buffers: they finish first (the caller waited for their fences;
  // this orders the GPU's view of them too).
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
  for (const BufferCopy& c : copies) {
    if (c.size == 0) continue;
    const VkBufferCopy region{0, 0, c.size};
    vkCmdCopyBuffer(cmd, c.source->buffer, c.destination->buffer, 1, &region);
  }
  if (!copies.empty()) {
    gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  }
  VkDeviceSize offset = 0;
  for (const BufferWrite& w : writes) {
    if (w.size == 0) continue;
    std::memcpy(static_cast<char*>(buffer.mapped) + offset, w.data, w.size);
    const VkBufferCopy region{offset, w.offset, w.size};
    vkCmdCopyBuffer(cmd, buffer.buffer, w.destination->buffer, 1, &region);
    offset += w.size;
  }
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  gpu::submitAndWait(context, recorder);
}

// --- SceneBuffers: poses ------------------------------------------------------------------------

bool SceneBuffers::poseDiffers(const ScenePose& pose) const {
  if (!posing || !posing->lastPose) return !pose.transforms.empty() || !pose.poses.empty() || posing;
  return posing->lastPose.get() != &pose && !samePose(*posing->lastPose, pose);
}

void SceneBuffers::applyPose(gpu::CommandRecorder& recorder, std::shared_ptr<const ScenePose> pose) {
  const bool posed = posing && !posing->posed.empty();
  // Everything is checked before anything changes.
  std::vector<glm::vec4> content;
  if (posed) {
    content = posing->poseContent(*pose);
  } else if (!pose->poses.empty()) {
    throw std::invalid_argument("pose of instance " + std::to_string(pose->poses[0].instance) +
                                ", which is not skinned or morphed");
  }
  if (!pose->transforms.empty()) updateInstances(recorder, {pose->transforms, bounds});
  if (!posed) {
    if (!posing) {
      posing = std::make_unique<ScenePosing>(context);
      posing->posedOf.assign(instanceCount, MYRIAD_SKIN_NONE);
    }
    posing->lastPose = std::move(pose);
    bounds = poseBounds();
    return;
  }
  for (const InstanceWrite& w : pose->transforms) {
    if (posing->posedOf[w.index] != MYRIAD_SKIN_NONE) posing->transforms[posing->posedOf[w.index]] = w.transform;
  }
  writeBuffers(context, recorder, {},
               {{&posing->pose, 0, content.data(), VkDeviceSize(content.size() * sizeof(glm::vec4))}});
  // The deformed draws' culling spheres; what was drawn of them before (the sun's map) is stale.
  std::vector<glm::vec4> moved;
  for (size_t k = 0; k < posing->posed.size(); ++k) {
    const ScenePosing::Posed& p = posing->posed[k];
    if (drawOfInstance_[p.instance] == UINT32_MAX) continue;
    DrawItem& draw = draws[drawOfInstance_[p.instance]];
    moved.emplace_back(draw.centre, draw.radius);
    const glm::vec4 sphere = posing->posedSphere(p, content);
    const glm::mat4& transform = posing->transforms[k];
    const glm::mat3 axes(transform);
    draw.unitScale = std::max({glm::length(axes[0]), glm::length(axes[1]), glm::length(axes[2])});
    draw.centre = glm::vec3(transform * glm::vec4(glm::vec3(sphere), 1.0f));
    draw.radius = sphere.w * draw.unitScale;
    moved.emplace_back(draw.centre, draw.radius);
  }
  geometryMoved(std::move(moved));
  posing->dirty = true;
  posing->lastPose = std::move(pose);
  bounds = poseBounds();
}

// The bounds of the scene as built, grown by where the pose put its draws.
scene::Bounds SceneBuffers::poseBounds() const {
  scene::Bounds b = restBounds_;
  if (!posing) return b;
  const std::vector<InstanceWrite> none;
  for (const InstanceWrite& w : posing->lastPose ? posing->lastPose->transforms : none) {
    if (w.index < drawOfInstance_.size() && drawOfInstance_[w.index] != UINT32_MAX) {
      const DrawItem& draw = draws[drawOfInstance_[w.index]];
      extendBySphere(b, draw.centre, draw.radius);
    }
  }
  for (const ScenePosing::Posed& p : posing->posed) {
    if (drawOfInstance_[p.instance] == UINT32_MAX) continue;
    const DrawItem& draw = draws[drawOfInstance_[p.instance]];
    extendBySphere(b, draw.centre, draw.radius);
  }
  return b;
}

bool SceneBuffers::previousDiffers(const ScenePose& previous) const {
  if (!posing || !posing->lastPrevious || posing->previousGeneration != generation) return true;
  return posing->lastPrevious.get() != &previous && !samePose(*posing->lastPrevious, previous);
}

void SceneBuffers::applyPrevious(gpu::CommandRecorder& recorder,
                                 std::shared_ptr<const ScenePose> previous) {
  if (!posing) {
    posing = std::make_unique<ScenePosing>(context);
    posing->posedOf.assign(instanceCount, MYRIAD_SKIN_NONE);
  }
  ScenePosing& p = *posing;
  const bool posed = !p.posed.empty();
  std::vector<glm::vec4> content;
  if (posed) {
    content = p.poseContent(*previous);
  } else if (!previous->poses.empty()) {
    throw std::invalid_argument("previous pose of instance " +
                                std::to_string(previous->poses[0].instance) +
                                ", which is not skinned or morphed");
  }
  for (const InstanceWrite& w : previous->transforms) {
    if (w.index >= instanceCount || !finiteTransform(w.transform)) {
      throw std::invalid_argument("previous transform of instance " + std::to_string(w.index) +
                                  " is past the instances or not finite");
    }
  }
  if (!p.motionArena) {
    p.motionArena = std::make_unique<gpu::Arena>(context, 256ull << 10);
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    p.previousInstances = p.motionArena->createBuffer(
        std::max<VkDeviceSize>(instances.size, 16), usage, gpu::MemoryUse::DeviceLocal);
    p.vertexRecords = p.motionArena->createBuffer(
        std::max<VkDeviceSize>(VkDeviceSize(instanceCount) * 16, 16), usage, gpu::MemoryUse::DeviceLocal);
    p.previousPositions = p.motionArena->createBuffer(
        std::max<VkDeviceSize>(VkDeviceSize(p.previousVertices) * 16, 16), usage,
        gpu::MemoryUse::DeviceLocal);
    p.previousPose = p.motionArena->createBuffer(
        std::max<VkDeviceSize>(VkDeviceSize(p.poseVec4s) * 16, 16), usage, gpu::MemoryUse::DeviceLocal);
    std::vector<glm::uvec4> records(instanceCount, glm::uvec4(MYRIAD_SKIN_NONE, 0u, 0u, 0u));
    for (const ScenePosing::Posed& q : p.posed) records[q.instance] = glm::uvec4(q.firstPrevious, q.firstPosed, 0u, 0u);
    writeBuffers(context, recorder, {},
                 {{&p.vertexRecords, 0, records.data(), VkDeviceSize(records.size() * 16)}});
    if (p.pool) {  // the pre-pass's sets name the buffers made here: made again
      vkDestroyDescriptorPool(context.device, p.pool, nullptr);
      p.pool = VK_NULL_HANDLE;
      p.currentSet = p.previousSet = VK_NULL_HANDLE;
    }
  }
  // The previous placements: this frame's, with the previous pose's transforms over them (only
  // the model matrix: the motion pass reads nothing else).
  std::vector<BufferWrite> writes;
  for (const InstanceWrite& w : previous->transforms) {
    writes.push_back({&p.previousInstances, VkDeviceSize(w.index) * sizeof(gpu_types::GpuInstance),
                      &w.transform, sizeof(glm::mat4)});
  }
  if (posed) {
    writes.push_back({&p.previousPose, 0, content.data(), VkDeviceSize(content.size() * sizeof(glm::vec4))});
  }
  writeBuffers(context, recorder, {{&instances, &p.previousInstances, instances.size}}, writes);
  p.previousDirty = posed;
  p.previousGeneration = generation;
  p.lastPrevious = std::move(previous);
}

}  // namespace myriad::render
