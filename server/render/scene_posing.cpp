// A scene's posing planned on the host (planPosing: regions, jobs, rest tables) and uploaded,
// and the host side of a pose: each posed instance's joints and morph weights as the pose buffer
// holds them, and the bounds its posed mesh may reach.
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

namespace {

constexpr uint32_t kNone = MYRIAD_SKIN_NONE;

// A joint matrix as the pose buffer holds it: its three rows (the affine part).
void storeRows(const glm::mat4& m, glm::vec4* rows) {
  for (int r = 0; r < 3; ++r) rows[r] = glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]);
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
        if (!finiteTransform(ip.joints[j])) {
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

bool finiteTransform(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

}  // namespace myriad::render
