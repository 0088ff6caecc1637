#include "render/skinning.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "render/scene_buffers.h"

namespace myriad::render {

static_assert(sizeof(scene::Vertex) == MYRIAD_VERTEX_FLOATS * sizeof(float));
static_assert(offsetof(scene::Vertex, normal) == 3 * sizeof(float) &&
              offsetof(scene::Vertex, tangent) == 8 * sizeof(float));
static_assert(sizeof(gpu_types::SkinJob) == 48 && sizeof(gpu_types::SkinPush) == 16);
static_assert(sizeof(gpu_types::MotionPush) == 80);

namespace {

constexpr uint32_t kNone = MYRIAD_SKIN_NONE;

// A joint matrix as the pose buffer holds it: its three rows (the affine part).
void storeRows(const glm::mat4& m, glm::vec4* rows) {
  for (int r = 0; r < 3; ++r) rows[r] = glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]);
}

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

void setWeight(std::vector<glm::vec4>& content, uint32_t index, float weight) {
  content[index / 4][int(index % 4)] = weight;
}

// The nodes' world transforms in the asset's space (parents come first: scene::Node::parent).
std::vector<glm::mat4> restNodeTransforms(const scene::Scene& scene) {
  std::vector<glm::mat4> world(scene.nodes.size(), glm::mat4(1.0f));
  for (size_t i = 0; i < scene.nodes.size(); ++i) {
    const scene::Node& n = scene.nodes[i];
    const glm::mat4 local = glm::translate(glm::mat4(1.0f), n.translation) * glm::mat4_cast(n.rotation) *
                            glm::scale(glm::mat4(1.0f), n.scale);
    const bool hasParent = n.parent >= 0 && size_t(n.parent) < i;
    world[i] = hasParent ? world[size_t(n.parent)] * local : local;
  }
  return world;
}

bool skinnedWith(const scene::Scene& scene, const scene::Instance& instance) {
  const scene::Mesh& mesh = scene.meshes[instance.mesh];
  return instance.skin >= 0 && size_t(instance.skin) < scene.skins.size() && mesh.skinned() &&
         mesh.joints.size() == mesh.vertices.size() && mesh.weights.size() == mesh.vertices.size();
}

bool morphedUsable(const scene::Mesh& mesh) {
  if (!mesh.morphed()) return false;
  for (const scene::MorphTarget& t : mesh.morphTargets) {
    for (size_t n : {t.positions.size(), t.normals.size(), t.tangents.size()}) {
      if (n != 0 && n != mesh.vertices.size()) return false;
    }
  }
  return true;
}

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

ScenePosing::~ScenePosing() {
  if (pool) vkDestroyDescriptorPool(context.device, pool, nullptr);
}

std::unique_ptr<ScenePosing> planPosing(gpu::Context& context, const scene::Scene& scene,
                                        const std::vector<MeshRange>& ranges,
                                        std::vector<scene::Vertex>& vertices) {
  auto posing = std::make_unique<ScenePosing>(context);
  posing->posedOf.assign(scene.instances.size(), kNone);
  const std::vector<glm::mat4> nodeWorld = restNodeTransforms(scene);
  // Per mesh, shared by its instances: where its influences and morph targets start, which
  // joints its vertices use, its rest sphere and its targets' reach.
  struct MeshTables {
    uint32_t firstInfluence = kNone;
    uint32_t firstTarget = 0;
    std::vector<uint32_t> usedJoints;
    glm::vec3 centre{0.0f};
    float radius = 0.0f;
    std::vector<float> reach;
  };
  std::map<uint32_t, MeshTables> tables;
  std::vector<glm::uvec4> influences;
  std::vector<float> morphs;
  std::vector<glm::uvec4> targets;
  auto tablesOf = [&](uint32_t meshIndex, bool skinned) -> MeshTables& {
    auto [it, made] = tables.try_emplace(meshIndex);
    MeshTables& t = it->second;
    const scene::Mesh& mesh = scene.meshes[meshIndex];
    if (made) {
      scene::Bounds b;
      for (const scene::Vertex& v : mesh.vertices) b.extend(v.position);
      t.centre = b.empty() ? glm::vec3(0.0f) : b.center();
      for (const scene::Vertex& v : mesh.vertices) t.radius = std::max(t.radius, glm::length(v.position - t.centre));
      t.firstTarget = static_cast<uint32_t>(targets.size());
      if (morphedUsable(mesh)) {
        for (const scene::MorphTarget& target : mesh.morphTargets) {
          glm::uvec4 row(kNone, kNone, kNone, 0u);
          const std::vector<glm::vec3>* lists[3] = {&target.positions, &target.normals, &target.tangents};
          for (int a = 0; a < 3; ++a) {
            if (lists[a]->empty()) continue;
            row[a] = static_cast<uint32_t>(morphs.size());
            for (const glm::vec3& d : *lists[a]) morphs.insert(morphs.end(), {d.x, d.y, d.z});
          }
          float reach = 0.0f;
          for (const glm::vec3& d : target.positions) reach = std::max(reach, glm::length(d));
          t.reach.push_back(reach);
          targets.push_back(row);
        }
      }
    }
    if (skinned && t.firstInfluence == kNone) {
      t.firstInfluence = static_cast<uint32_t>(influences.size() / 2);
      std::vector<bool> used;
      for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        const glm::uvec4 j = mesh.joints[v];
        const glm::vec4 w = mesh.weights[v];
        influences.push_back(j);
        influences.push_back(glm::uvec4(std::bit_cast<uint32_t>(w.x), std::bit_cast<uint32_t>(w.y),
                                        std::bit_cast<uint32_t>(w.z), std::bit_cast<uint32_t>(w.w)));
        for (int i = 0; i < 4; ++i) {
          if (w[i] == 0.0f || j[i] > (1u << 20)) continue;
          if (used.size() <= j[i]) used.resize(j[i] + 1, false);
          used[j[i]] = true;
        }
      }
      for (uint32_t j = 0; j < used.size(); ++j) {
        if (used[j]) t.usedJoints.push_back(j);
      }
    }
    return t;
  };

  uint32_t jointRows = 0;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& instance = scene.instances[i];
    if (instance.mesh >= scene.meshes.size()) continue;  // SceneBuffers refuses the scene
    const scene::Mesh& mesh = scene.meshes[instance.mesh];
    const bool skinned = skinnedWith(scene, instance);
    const bool morphed = morphedUsable(mesh);
    if ((!skinned && !morphed) || mesh.vertices.empty()) continue;
    const MeshTables& t = tablesOf(instance.mesh, skinned);
    ScenePosing::Posed p;
    p.instance = i;
    p.mesh = instance.mesh;
    p.firstRest = static_cast<uint32_t>(ranges[instance.mesh].vertexOffset);
    p.vertexCount = static_cast<uint32_t>(mesh.vertices.size());
    p.firstPosed = static_cast<uint32_t>(vertices.size());
    vertices.insert(vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
    if (skinned) {
      p.firstInfluence = t.firstInfluence;
      p.jointCount = static_cast<uint32_t>(scene.skins[size_t(instance.skin)].joints.size());
      p.usedJoints = t.usedJoints;
      p.firstJointRow = jointRows;
      jointRows += 3 * p.jointCount;
    }
    if (morphed) {
      p.firstTarget = t.firstTarget;
      p.targetCount = static_cast<uint32_t>(mesh.morphTargets.size());
      p.targetReach = t.reach;
    }
    p.restCentre = t.centre;
    p.restRadius = t.radius;
    p.firstPrevious = posing->previousVertices;
    posing->previousVertices += p.vertexCount;
    posing->mostVertices = std::max(posing->mostVertices, p.vertexCount);
    posing->posedOf[i] = static_cast<uint32_t>(posing->posed.size());
    posing->posed.push_back(std::move(p));
    posing->transforms.push_back(instance.transform);
  }
  if (posing->posed.empty()) return nullptr;

  // The pose buffer: every skinned instance's joint rows, then every morphed one's weights.
  uint32_t weights = 0;
  for (ScenePosing::Posed& p : posing->posed) {
    p.firstWeight = jointRows * 4 + weights;
    weights += p.targetCount;
  }
  posing->poseVec4s = std::max(1u, jointRows + (weights + 3) / 4);
  posing->restPose.assign(posing->poseVec4s, glm::vec4(0.0f));
  for (const ScenePosing::Posed& p : posing->posed) {
    const scene::Instance& instance = scene.instances[p.instance];
    if (p.firstInfluence != kNone) {
      const scene::Skin& skin = scene.skins[size_t(instance.skin)];
      for (uint32_t j = 0; j < p.jointCount; ++j) {
        const uint32_t node = skin.joints[j];
        const glm::mat4 world = node < nodeWorld.size() ? nodeWorld[node] : glm::mat4(1.0f);
        const glm::mat4 inverseBind = j < skin.inverseBind.size() ? skin.inverseBind[j] : glm::mat4(1.0f);
        storeRows(world * inverseBind, &posing->restPose[p.firstJointRow + 3 * j]);
      }
    }
    const scene::Mesh& mesh = scene.meshes[p.mesh];
    for (uint32_t k = 0; k < p.targetCount; ++k) {
      setWeight(posing->restPose, p.firstWeight + k, k < mesh.morphWeights.size() ? mesh.morphWeights[k] : 0.0f);
    }
  }
  posing->hostInfluences = std::move(influences);
  posing->hostMorphs = std::move(morphs);
  posing->hostTargets = std::move(targets);
  return posing;
}

void uploadPosing(ScenePosing& posing, gpu::Arena& arena, gpu::CommandRecorder& recorder) {
  std::vector<gpu_types::SkinJob> jobs;
  for (const ScenePosing::Posed& p : posing.posed) {
    gpu_types::SkinJob job{};
    job.vertices = glm::uvec4(p.firstRest, p.vertexCount, p.firstPosed, p.firstPrevious);
    job.skin = glm::uvec4(p.firstInfluence, p.firstJointRow, p.jointCount, 0u);
    job.morph = glm::uvec4(p.firstTarget, p.targetCount, p.firstWeight, 0u);
    jobs.push_back(job);
  }
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  auto make = [&](VkDeviceSize bytes) {
    return arena.createBuffer(std::max<VkDeviceSize>(bytes, 16), usage, gpu::MemoryUse::DeviceLocal);
  };
  auto bytes = [](const auto& v) { return VkDeviceSize(v.size() * sizeof(v[0])); };
  posing.influences = make(bytes(posing.hostInfluences));
  posing.morphs = make(bytes(posing.hostMorphs));
  posing.targets = make(bytes(posing.hostTargets));
  posing.jobs = make(bytes(jobs));
  posing.pose = make(bytes(posing.restPose));
  writeBuffers(posing.context, recorder, {},
               {{&posing.influences, 0, posing.hostInfluences.data(), bytes(posing.hostInfluences)},
                {&posing.morphs, 0, posing.hostMorphs.data(), bytes(posing.hostMorphs)},
                {&posing.targets, 0, posing.hostTargets.data(), bytes(posing.hostTargets)},
                {&posing.jobs, 0, jobs.data(), bytes(jobs)},
                {&posing.pose, 0, posing.restPose.data(), bytes(posing.restPose)}});
  posing.hostInfluences = {};
  posing.hostMorphs = {};
  posing.hostTargets = {};
  posing.dirty = true;  // the regions hold rest copies: the first frame poses them (morph defaults)
}

std::vector<glm::vec4> ScenePosing::poseContent(const ScenePose& pose) const {
  std::vector<glm::vec4> content = restPose;
  for (const InstancePose& ip : pose.poses) {
    if (ip.instance >= posedOf.size() || posedOf[ip.instance] == kNone) {
      throw std::invalid_argument("pose of instance " + std::to_string(ip.instance) +
                                  ", which is not skinned or morphed");
    }
    const Posed& p = posed[posedOf[ip.instance]];
    if (!ip.joints.empty()) {
      if (p.firstInfluence == kNone || ip.joints.size() != p.jointCount) {
        throw std::invalid_argument("pose of instance " + std::to_string(ip.instance) + " has " +
                                    std::to_string(ip.joints.size()) + " joint matrices; its skin has " +
                                    std::to_string(p.firstInfluence == kNone ? 0 : p.jointCount));
      }
      for (uint32_t j = 0; j < p.jointCount; ++j) {
        if (!finite(ip.joints[j])) {
          throw std::invalid_argument("pose of instance " + std::to_string(ip.instance) + ": joint " +
                                      std::to_string(j) + "'s matrix is not finite");
        }
        storeRows(ip.joints[j], &content[p.firstJointRow + 3 * j]);
      }
    }
    if (!ip.morphWeights.empty()) {
      if (ip.morphWeights.size() != p.targetCount) {
        throw std::invalid_argument("pose of instance " + std::to_string(ip.instance) + " has " +
                                    std::to_string(ip.morphWeights.size()) + " morph weights; its mesh has " +
                                    std::to_string(p.targetCount) + " targets");
      }
      for (uint32_t k = 0; k < p.targetCount; ++k) {
        if (!std::isfinite(ip.morphWeights[k])) {
          throw std::invalid_argument("pose of instance " + std::to_string(ip.instance) +
                                      ": a morph weight is not finite");
        }
        content[(p.firstWeight + k) / 4][int((p.firstWeight + k) % 4)] = ip.morphWeights[k];
      }
    }
  }
  return content;
}

glm::vec4 ScenePosing::posedSphere(const Posed& p, const std::vector<glm::vec4>& content) const {
  float radius = p.restRadius;
  for (uint32_t k = 0; k < p.targetCount; ++k) {
    const uint32_t w = p.firstWeight + k;
    radius += std::abs(content[w / 4][int(w % 4)]) * p.targetReach[k];
  }
  if (p.firstInfluence == kNone || p.usedJoints.empty()) return glm::vec4(p.restCentre, radius);
  // Each posed vertex is a weighted mean of its joints' images of it: inside the union of the
  // used joints' images of the rest sphere, which this sphere holds.
  std::vector<glm::vec4> images;  // centre, radius
  glm::vec3 mean(0.0f);
  for (uint32_t j : p.usedJoints) {
    if (j >= p.jointCount) continue;
    const glm::vec4* rows = &content[p.firstJointRow + 3 * j];
    const glm::vec4 c(p.restCentre, 1.0f);
    const glm::vec3 centre(glm::dot(rows[0], c), glm::dot(rows[1], c), glm::dot(rows[2], c));
    float scale = 0.0f;
    for (int col = 0; col < 3; ++col) {
      scale = std::max(scale, glm::length(glm::vec3(rows[0][col], rows[1][col], rows[2][col])));
    }
    images.emplace_back(centre, scale * radius);
    mean += centre;
  }
  if (images.empty()) return glm::vec4(p.restCentre, radius);
  mean /= float(images.size());
  float reach = 0.0f;
  for (const glm::vec4& s : images) reach = std::max(reach, glm::length(glm::vec3(s) - mean) + s.w);
  return glm::vec4(mean, reach);
}

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
    if (w.index >= instanceCount || !finite(w.transform)) {
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

// --- the pre-pass -------------------------------------------------------------------------------

SkinningPass::SkinningPass(gpu::Context& context) : context_(context) {
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_SKIN_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(context.device, bindings);
  const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(gpu_types::SkinPush)};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &setLayout_;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &push;
  VK_CHECK(vkCreatePipelineLayout(context.device, &info, nullptr, &layout_));
  pipeline_ = gpu::createComputePipeline(context.device, layout_, spirv::skinning_comp);
}

SkinningPass::~SkinningPass() {
  if (pipeline_) vkDestroyPipeline(context_.device, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(context_.device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(context_.device, setLayout_, nullptr);
}

bool SkinningPass::needed(const SceneBuffers& scene, bool previous) {
  const ScenePosing* p = scene.posing.get();
  if (!p || p->posed.empty()) return false;
  return p->dirty || (previous && p->motionArena && p->previousDirty);
}

void SkinningPass::ensureSets(SceneBuffers& scene) {
  ScenePosing& p = *scene.posing;
  if (p.pool) return;
  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * MYRIAD_SKIN_BINDINGS};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(context_.device, &poolInfo, nullptr, &p.pool));
  const VkDescriptorSetLayout layouts[] = {setLayout_, setLayout_};
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = p.pool;
  alloc.descriptorSetCount = 2;
  alloc.pSetLayouts = layouts;
  VkDescriptorSet sets[2];
  VK_CHECK(vkAllocateDescriptorSets(context_.device, &alloc, sets));
  p.currentSet = sets[0];
  p.previousSet = sets[1];
  // Without motion buffers the previous set is never bound; its bindings name the current
  // pose and the jobs (any storage buffer: the current mode never writes PREVIOUS).
  const gpu::Buffer& previousPositions = p.motionArena ? p.previousPositions : p.jobs;
  const gpu::Buffer& previousPose = p.motionArena ? p.previousPose : p.pose;
  for (int s = 0; s < 2; ++s) {
    const VkDescriptorBufferInfo infos[MYRIAD_SKIN_BINDINGS] = {
        {scene.vertices.buffer, 0, VK_WHOLE_SIZE}, {p.influences.buffer, 0, VK_WHOLE_SIZE},
        {p.morphs.buffer, 0, VK_WHOLE_SIZE},       {p.targets.buffer, 0, VK_WHOLE_SIZE},
        {p.jobs.buffer, 0, VK_WHOLE_SIZE},
        {(s == 0 ? p.pose : previousPose).buffer, 0, VK_WHOLE_SIZE},
        {previousPositions.buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet writes[MYRIAD_SKIN_BINDINGS];
    for (uint32_t i = 0; i < MYRIAD_SKIN_BINDINGS; ++i) {
      writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[i].dstSet = sets[s];
      writes[i].dstBinding = i;
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(context_.device, MYRIAD_SKIN_BINDINGS, writes, 0, nullptr);
  }
}

void SkinningPass::record(VkCommandBuffer cmd, SceneBuffers& scene, bool previous,
                          gpu::PassTimer& timer) {
  if (!needed(scene, previous)) return;
  ScenePosing& p = *scene.posing;
  ensureSets(scene);  // (SceneBuffers refused a scene whose vertices one range cannot reach)
  timer.beginPass(cmd, "skin");
  // Earlier readers of the regions (vertex input, the compute G-buffer, the motion pass) and the
  // pre-pass's own earlier writes come first.
  gpu::memoryBarrier(cmd,
                     VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
  const uint32_t jobs = static_cast<uint32_t>(p.posed.size());
  const uint32_t groupsX = gpu::groupCount(p.mostVertices, MYRIAD_SKIN_GROUP);
  auto dispatch = [&](VkDescriptorSet set, uint32_t mode) {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
    // Workgroup counts past 65535 are not guaranteed: jobs in batches.
    for (uint32_t first = 0; first < jobs; first += 65535u) {
      const gpu_types::SkinPush push{glm::uvec4(mode, first, 0u, 0u)};
      vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      vkCmdDispatch(cmd, groupsX, std::min(jobs - first, 65535u), 1);
    }
  };
  if (p.dirty) {
    dispatch(p.currentSet, 0);
    p.dirty = false;
  }
  if (previous && p.motionArena && p.previousDirty) {
    dispatch(p.previousSet, 1);
    p.previousDirty = false;
  }
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT |
                         VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

}  // namespace myriad::render
