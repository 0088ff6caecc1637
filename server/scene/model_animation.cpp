#include "scene/model_animation.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <assimp/anim.h>
#include <assimp/mesh.h>
#include <assimp/scene.h>

#include "scene/animation.h"

namespace myriad::scene::detail {

namespace {

glm::vec3 toGlm(const aiVector3D& v) {
  return {v.x, v.y, v.z};
}

glm::mat4 toGlm(const aiMatrix4x4& m) {
  return glm::mat4(m.a1, m.b1, m.c1, m.d1, m.a2, m.b2, m.c2, m.d2, m.a3, m.b3, m.c3, m.d3, m.a4,
                   m.b4, m.c4, m.d4);
}

std::vector<uint32_t> sourceToConverted(const SourceVertices& sourceOf, unsigned sourceCount) {
  std::vector<uint32_t> map(sourceCount, UINT32_MAX);
  for (size_t v = 0; v < sourceOf.size(); ++v) {
    if (sourceOf[v] < sourceCount) map[sourceOf[v]] = uint32_t(v);
  }
  return map;
}

int32_t firstNode(const std::unordered_multimap<std::string, uint32_t>& nodesByName,
                  const std::string& name) {
  const auto [begin, end] = nodesByName.equal_range(name);
  int32_t best = -1;
  for (auto it = begin; it != end; ++it) {
    if (best < 0 || int32_t(it->second) < best) best = int32_t(it->second);
  }
  return best;
}

// Times in seconds from Assimp's ticks (0 ticks per second: Assimp's "unknown", taken as 25).
struct KeyTimes {
  double ticksPerSecond;
  // Adds key time `ticks` if it follows the previous one; false for a key to skip (a repeated or
  // earlier time: some exporters write them). Non-finite: `bad`.
  bool accept(double ticks, std::vector<float>& times, bool& bad) const {
    double seconds = ticks / ticksPerSecond;
    if (!std::isfinite(seconds)) {
      bad = true;
      return false;
    }
    seconds = std::max(seconds, 0.0);
    if (!times.empty() && !(float(seconds) > times.back())) return false;
    times.push_back(float(seconds));
    return true;
  }
};

}  // namespace

bool readMorphTargets(const aiMesh& source, const SourceVertices& sourceOf, Mesh& mesh,
                      std::string& reason) {
  if (source.mNumAnimMeshes == 0 || source.mAnimMeshes == nullptr) return true;
  if (source.mNumAnimMeshes > kMaxMorphTargets) {
    reason = "mesh '" + mesh.name + "' has " + std::to_string(source.mNumAnimMeshes) +
             " morph targets (at most " + std::to_string(kMaxMorphTargets) + ")";
    return false;
  }
  for (unsigned t = 0; t < source.mNumAnimMeshes; ++t) {
    const aiAnimMesh* anim = source.mAnimMeshes[t];
    MorphTarget target;
    float weight = 0.0f;
    if (anim != nullptr && anim->mNumVertices == source.mNumVertices) {
      target.name = anim->mName.C_Str();
      weight = std::isfinite(anim->mWeight) ? anim->mWeight : 0.0f;
      auto deltas = [&](const aiVector3D* values, const aiVector3D* rest,
                        std::vector<glm::vec3>& out) {
        if (values == nullptr || rest == nullptr) return;
        out.resize(sourceOf.size());
        bool any = false;
        for (size_t v = 0; v < sourceOf.size(); ++v) {
          const glm::vec3 d = toGlm(values[sourceOf[v]]) - toGlm(rest[sourceOf[v]]);
          out[v] = std::isfinite(d.x + d.y + d.z) ? d : glm::vec3(0.0f);
          any = any || out[v] != glm::vec3(0.0f);
        }
        if (!any) out.clear();  // moves nothing: not carried
      };
      deltas(anim->mVertices, source.mVertices, target.positions);
      deltas(anim->mNormals, source.mNormals, target.normals);
      deltas(anim->mTangents, source.mTangents, target.tangents);
    }
    mesh.morphTargets.push_back(std::move(target));
    mesh.morphWeights.push_back(weight);
  }
  return true;
}

bool readSkinWeights(const aiMesh& source, const SourceVertices& sourceOf, Mesh& mesh,
                     std::string& reason) {
  if (source.mNumBones == 0 || source.mBones == nullptr) return true;
  if (source.mNumBones > kMaxJointsPerSkin) {
    reason = "mesh '" + mesh.name + "' is skinned to " + std::to_string(source.mNumBones) +
             " joints (at most " + std::to_string(kMaxJointsPerSkin) + ")";
    return false;
  }
  const std::vector<uint32_t> converted = sourceToConverted(sourceOf, source.mNumVertices);
  const size_t n = sourceOf.size();
  // The four largest influences per vertex, kept sorted (largest first) as they arrive.
  std::vector<std::array<std::pair<float, uint32_t>, 4>> best(n);
  for (auto& slots : best) slots.fill({0.0f, 0u});
  for (unsigned b = 0; b < source.mNumBones; ++b) {
    const aiBone* bone = source.mBones[b];
    if (bone == nullptr || bone->mWeights == nullptr) continue;
    for (unsigned w = 0; w < bone->mNumWeights; ++w) {
      const aiVertexWeight& vw = bone->mWeights[w];
      if (vw.mVertexId >= converted.size() || converted[vw.mVertexId] == UINT32_MAX) continue;
      const float weight = vw.mWeight;
      if (!(weight > 0.0f) || !std::isfinite(weight)) continue;
      auto& slots = best[converted[vw.mVertexId]];
      if (weight <= slots[3].first) continue;
      slots[3] = {weight, b};
      for (int k = 3; k > 0 && slots[k].first > slots[k - 1].first; --k)
        std::swap(slots[k], slots[k - 1]);
    }
  }
  mesh.joints.resize(n);
  mesh.weights.resize(n);
  for (size_t v = 0; v < n; ++v) {
    const auto& slots = best[v];
    const float sum = slots[0].first + slots[1].first + slots[2].first + slots[3].first;
    if (!(sum > 0.0f)) {
      mesh.joints[v] = glm::uvec4(0);
      mesh.weights[v] = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
      continue;
    }
    mesh.joints[v] = {slots[0].second, slots[1].second, slots[2].second, slots[3].second};
    mesh.weights[v] =
        glm::vec4(slots[0].first, slots[1].first, slots[2].first, slots[3].first) / sum;
  }
  return true;
}

bool readSkin(const aiMesh& source,
              const std::unordered_multimap<std::string, uint32_t>& nodesByName, Skin& skin,
              std::string& reason) {
  skin.joints.clear();
  skin.inverseBind.clear();
  for (unsigned b = 0; b < source.mNumBones; ++b) {
    const aiBone* bone = source.mBones[b];
    const std::string name = bone != nullptr ? bone->mName.C_Str() : "";
    const int32_t node = firstNode(nodesByName, name);
    if (node < 0) {
      reason = "mesh '" + std::string(source.mName.C_Str()) + "' is skinned to a joint '" +
               name.substr(0, 64) + "' that is not a node of the model";
      return false;
    }
    const glm::mat4 inverseBind = toGlm(bone->mOffsetMatrix);
    skin.joints.push_back(uint32_t(node));
    skin.inverseBind.push_back(inverseBind);
  }
  return true;
}

bool readAnimations(const aiScene& source,
                    const std::unordered_multimap<std::string, uint32_t>& nodesByName,
                    const Scene& scene, std::vector<Animation>& animations, std::string& reason) {
  if (source.mAnimations == nullptr || source.mNumAnimations == 0) return true;
  if (source.mNumAnimations > kMaxAnimations) {
    reason = "it has " + std::to_string(source.mNumAnimations) + " animations (at most " +
             std::to_string(kMaxAnimations) + ")";
    return false;
  }
  // Morph target count per node (of the first mesh it holds).
  std::vector<uint32_t> targets(scene.nodes.size(), 0);
  for (const Instance& instance : scene.instances) {
    if (instance.node >= 0 && instance.mesh < scene.meshes.size() &&
        targets[size_t(instance.node)] == 0) {
      targets[size_t(instance.node)] = uint32_t(scene.meshes[instance.mesh].morphTargets.size());
    }
  }
  size_t floats = 0, channels = 0;
  auto budget = [&](size_t more) {
    floats += more;
    if (floats <= kMaxAnimationFloats) return true;
    reason =
        "its animation keys hold more than " + std::to_string(kMaxAnimationFloats) + " numbers";
    return false;
  };
  for (unsigned a = 0; a < source.mNumAnimations; ++a) {
    const aiAnimation* anim = source.mAnimations[a];
    if (anim == nullptr) continue;
    Animation animation;
    animation.name =
        anim->mName.length > 0 ? anim->mName.C_Str() : "animation " + std::to_string(a);
    const KeyTimes clock{anim->mTicksPerSecond > 0.0 ? anim->mTicksPerSecond : 25.0};
    bool bad = false;
    auto addVectorChannel = [&](uint32_t node, AnimationPath path, const aiVectorKey* keys,
                                unsigned count) {
      if (keys == nullptr || count == 0) return true;
      if (!budget(size_t(count) * 4)) return false;
      AnimationChannel channel{node, path, Interpolation::linear, {}, {}};
      for (unsigned k = 0; k < count; ++k) {
        if (!clock.accept(keys[k].mTime, channel.times, bad)) continue;
        const aiVector3D& v = keys[k].mValue;
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) bad = true;
        channel.values.insert(channel.values.end(), {v.x, v.y, v.z});
      }
      animation.channels.push_back(std::move(channel));
      return true;
    };
    for (unsigned c = 0; anim->mChannels != nullptr && c < anim->mNumChannels; ++c) {
      const aiNodeAnim* channel = anim->mChannels[c];
      if (channel == nullptr) continue;
      const int32_t node = firstNode(nodesByName, channel->mNodeName.C_Str());
      if (node < 0) continue;
      channels += 3;
      if (channels > kMaxAnimationChannels) {
        reason =
            "its animations have more than " + std::to_string(kMaxAnimationChannels) + " channels";
        return false;
      }
      if (!addVectorChannel(uint32_t(node), AnimationPath::translation, channel->mPositionKeys,
                            channel->mNumPositionKeys) ||
          !addVectorChannel(uint32_t(node), AnimationPath::scale, channel->mScalingKeys,
                            channel->mNumScalingKeys)) {
        return false;
      }
      if (channel->mRotationKeys != nullptr && channel->mNumRotationKeys > 0) {
        if (!budget(size_t(channel->mNumRotationKeys) * 5)) return false;
        AnimationChannel rotation{
            uint32_t(node), AnimationPath::rotation, Interpolation::linear, {}, {}};
        for (unsigned k = 0; k < channel->mNumRotationKeys; ++k) {
          if (!clock.accept(channel->mRotationKeys[k].mTime, rotation.times, bad)) continue;
          const aiQuaternion& q = channel->mRotationKeys[k].mValue;
          glm::quat value(q.w, q.x, q.y, q.z);
          const float length = glm::length(value);
          if (!std::isfinite(length)) bad = true;
          value = length > 1e-12f && std::isfinite(length) ? value / length : glm::quat(1, 0, 0, 0);
          rotation.values.insert(rotation.values.end(), {value.x, value.y, value.z, value.w});
        }
        animation.channels.push_back(std::move(rotation));
      }
    }
    for (unsigned c = 0; anim->mMorphMeshChannels != nullptr && c < anim->mNumMorphMeshChannels;
         ++c) {
      const aiMeshMorphAnim* channel = anim->mMorphMeshChannels[c];
      if (channel == nullptr || channel->mKeys == nullptr || channel->mNumKeys == 0) continue;
      const int32_t node = firstNode(nodesByName, channel->mName.C_Str());
      if (node < 0 || targets[size_t(node)] == 0) continue;
      const uint32_t width = targets[size_t(node)];
      if (++channels > kMaxAnimationChannels) {
        reason =
            "its animations have more than " + std::to_string(kMaxAnimationChannels) + " channels";
        return false;
      }
      if (!budget(size_t(channel->mNumKeys) * (1 + width))) return false;
      AnimationChannel weights{
          uint32_t(node), AnimationPath::weights, Interpolation::linear, {}, {}};
      for (unsigned k = 0; k < channel->mNumKeys; ++k) {
        const aiMeshMorphKey& key = channel->mKeys[k];
        if (!clock.accept(key.mTime, weights.times, bad)) continue;
        const size_t at = weights.values.size();
        weights.values.resize(at + width, 0.0f);
        for (unsigned j = 0;
             key.mValues != nullptr && key.mWeights != nullptr && j < key.mNumValuesAndWeights;
             ++j) {
          if (!std::isfinite(key.mWeights[j])) bad = true;
          if (key.mValues[j] < width) weights.values[at + key.mValues[j]] = float(key.mWeights[j]);
        }
      }
      animation.channels.push_back(std::move(weights));
    }
    if (bad) {
      reason =
          "animation '" + animation.name.substr(0, 64) + "' has a non-finite key (NaN or infinite)";
      return false;
    }
    for (const AnimationChannel& channel : animation.channels) {
      animation.duration = std::max(animation.duration, channel.times.back());
    }
    if (!animation.channels.empty()) animations.push_back(std::move(animation));
  }
  return true;
}

}  // namespace myriad::scene::detail
