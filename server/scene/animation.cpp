#include "scene/animation.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <unordered_map>

#include <glm/gtc/matrix_transform.hpp>

namespace myriad::scene {

namespace {

bool finite(float v) {
  return std::isfinite(v);
}

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

bool finite(const glm::vec3& v) {
  return std::isfinite(v.x + v.y + v.z) && finite(v.x) && finite(v.y) && finite(v.z);
}

// The key interval holding t: k with times[k] <= t < times[k+1] (binary search), clamped.
size_t keyBefore(const std::vector<float>& times, double t) {
  const auto it = std::upper_bound(times.begin(), times.end(), t,
                                   [](double value, float key) { return value < double(key); });
  const size_t after = size_t(it - times.begin());
  return after == 0 ? 0 : after - 1;
}

// Per node, the morph target count of the first mesh it holds (what a weights channel sets).
std::vector<uint32_t> targetCounts(const Scene& scene) {
  std::vector<uint32_t> counts(scene.nodes.size(), 0);
  for (const Instance& instance : scene.instances) {
    if (instance.node >= 0 && size_t(instance.node) < counts.size() &&
        instance.mesh < scene.meshes.size() && counts[size_t(instance.node)] == 0) {
      counts[size_t(instance.node)] = uint32_t(scene.meshes[instance.mesh].morphTargets.size());
    }
  }
  return counts;
}

}  // namespace

size_t keyWidth(AnimationPath path, size_t targets) {
  switch (path) {
    case AnimationPath::translation:
    case AnimationPath::scale:
      return 3;
    case AnimationPath::rotation:
      return 4;
    case AnimationPath::weights:
      return targets;
  }
  return 0;
}

std::optional<std::string> checkAnimationData(const Scene& scene) {
  if (scene.nodes.size() > kMaxNodes) {
    return "it has more than " + std::to_string(kMaxNodes) + " nodes";
  }
  for (size_t i = 0; i < scene.nodes.size(); ++i) {
    const Node& node = scene.nodes[i];
    // Parents first: this also rules out a cycle of parents.
    if (node.parent >= int32_t(i) || node.parent < -1) {
      return "node " + std::to_string(i) + "'s parent is not an earlier node (a cycle of parents?)";
    }
    if (!finite(node.translation) || !finite(node.scale) ||
        !std::isfinite(node.rotation.x + node.rotation.y + node.rotation.z + node.rotation.w)) {
      return "node " + std::to_string(i) + " has a non-finite transform";
    }
  }
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& instance = scene.instances[i];
    if (instance.node < -1 || instance.node >= int32_t(scene.nodes.size())) {
      return "instance " + std::to_string(i) + " names node " + std::to_string(instance.node) +
             ", which the model does not have";
    }
    if (instance.skin < -1 || instance.skin >= int32_t(scene.skins.size())) {
      return "instance " + std::to_string(i) + " names skin " + std::to_string(instance.skin) +
             ", which the model does not have";
    }
    if (instance.mesh >= scene.meshes.size()) continue;
    const Mesh& mesh = scene.meshes[instance.mesh];
    if (instance.skin >= 0 && !mesh.skinned()) {
      // The renderer poses only meshes with joints: a skin on any other is a lie.
      return "instance " + std::to_string(i) + " has a skin but its mesh '" + mesh.name +
             "' has no joints and weights";
    }
    if (instance.skin >= 0) {
      const size_t joints = scene.skins[size_t(instance.skin)].joints.size();
      for (const glm::uvec4& j : mesh.joints) {
        if (j.x >= joints || j.y >= joints || j.z >= joints || j.w >= joints) {
          return "mesh '" + mesh.name +
                 "' has a vertex weighted to a joint out of range (its skin has " +
                 std::to_string(joints) + " joints)";
        }
      }
    } else if (mesh.skinned()) {
      return "mesh '" + mesh.name + "' has joints and weights but its instance " +
             std::to_string(i) + " has no skin";
    }
  }
  if (scene.skins.size() > kMaxSkins) {
    return "it has more than " + std::to_string(kMaxSkins) + " skins";
  }
  for (size_t s = 0; s < scene.skins.size(); ++s) {
    const Skin& skin = scene.skins[s];
    if (skin.joints.empty() || skin.joints.size() > kMaxJointsPerSkin) {
      return "skin " + std::to_string(s) + " has " + std::to_string(skin.joints.size()) +
             " joints (1 to " + std::to_string(kMaxJointsPerSkin) + " are allowed)";
    }
    if (skin.inverseBind.size() != skin.joints.size()) {
      return "skin " + std::to_string(s) + " has not one inverse bind matrix per joint";
    }
    for (size_t j = 0; j < skin.joints.size(); ++j) {
      if (skin.joints[j] >= scene.nodes.size()) {
        return "skin " + std::to_string(s) + "'s joint " + std::to_string(j) +
               " is not a node of the model";
      }
      if (!finite(skin.inverseBind[j])) {
        return "skin " + std::to_string(s) + " has a non-finite inverse bind matrix";
      }
    }
  }
  size_t morphVectors = 0;
  for (const Mesh& mesh : scene.meshes) {
    const size_t n = mesh.vertices.size();
    if (!mesh.joints.empty() || !mesh.weights.empty()) {
      if (mesh.joints.size() != n || mesh.weights.size() != n) {
        return "mesh '" + mesh.name + "' has not one set of joints and weights per vertex";
      }
      for (const glm::vec4& w : mesh.weights) {
        if (!std::isfinite(w.x + w.y + w.z + w.w) || w.x < 0 || w.y < 0 || w.z < 0 || w.w < 0) {
          return "mesh '" + mesh.name + "' has a negative or non-finite skin weight";
        }
      }
    }
    if (mesh.morphTargets.size() > kMaxMorphTargets) {
      return "mesh '" + mesh.name + "' has more than " + std::to_string(kMaxMorphTargets) +
             " morph targets";
    }
    if (mesh.morphWeights.size() != mesh.morphTargets.size()) {
      return "mesh '" + mesh.name + "' has not one default weight per morph target";
    }
    for (float w : mesh.morphWeights) {
      if (!std::isfinite(w)) return "mesh '" + mesh.name + "' has a non-finite morph weight";
    }
    for (const MorphTarget& target : mesh.morphTargets) {
      for (const std::vector<glm::vec3>* list :
           {&target.positions, &target.normals, &target.tangents}) {
        if (!list->empty() && list->size() != n) {
          return "mesh '" + mesh.name + "' has a morph target without one entry per vertex";
        }
        morphVectors += list->size();
        if (morphVectors > kMaxMorphVectors) {
          return "its morph targets hold more than " + std::to_string(kMaxMorphVectors) +
                 " displacements";
        }
        for (const glm::vec3& v : *list) {
          if (!finite(v)) return "mesh '" + mesh.name + "' has a non-finite morph displacement";
        }
      }
    }
  }
  if (scene.animations.size() > kMaxAnimations) {
    return "it has more than " + std::to_string(kMaxAnimations) + " animations";
  }
  size_t channels = 0, floats = 0;
  const std::vector<uint32_t> targets = targetCounts(scene);
  for (const Animation& animation : scene.animations) {
    const std::string name = "animation '" + animation.name + "'";
    channels += animation.channels.size();
    if (channels > kMaxAnimationChannels) {
      return "its animations have more than " + std::to_string(kMaxAnimationChannels) + " channels";
    }
    if (!std::isfinite(animation.duration) || animation.duration < 0.0f ||
        animation.duration > kMaxAnimationSeconds) {
      return name + " has a duration outside 0 to " + std::to_string(int(kMaxAnimationSeconds)) +
             " s";
    }
    for (const AnimationChannel& channel : animation.channels) {
      if (channel.node >= scene.nodes.size())
        return name + " animates a node the model does not have";
      floats += channel.times.size() + channel.values.size();
      if (floats > kMaxAnimationFloats) {
        return "its animation keys hold more than " + std::to_string(kMaxAnimationFloats) +
               " numbers";
      }
      if (channel.times.empty()) return name + " has a channel without keys";
      for (size_t k = 0; k < channel.times.size(); ++k) {
        const float t = channel.times[k];
        if (!std::isfinite(t) || t < 0.0f || t > kMaxAnimationSeconds) {
          return name + " has a key time that is not finite or outside 0 to " +
                 std::to_string(int(kMaxAnimationSeconds)) + " s";
        }
        if (k > 0 && !(t > channel.times[k - 1])) {
          return name + " has key times that do not increase";
        }
      }
      const size_t width = keyWidth(channel.path, targets[channel.node]);
      if (width == 0) return name + " animates the weights of a node without morph targets";
      const size_t perKey = channel.interpolation == Interpolation::cubicSpline ? 3 * width : width;
      if (channel.values.size() != perKey * channel.times.size()) {
        return name + " has a channel whose values do not match its keys";
      }
      for (float v : channel.values) {
        if (!std::isfinite(v)) return name + " has a non-finite key value";
      }
    }
  }
  return std::nullopt;
}

glm::mat4 localMatrix(const Node& node) {
  return glm::translate(glm::mat4(1.0f), node.translation) * glm::mat4_cast(node.rotation) *
         glm::scale(glm::mat4(1.0f), node.scale);
}

double clipTime(const Animation& clip, double seconds, bool loop) {
  const double duration = clip.duration;
  if (!(duration > 0.0) || !std::isfinite(seconds)) return 0.0;
  if (loop) {
    double t = std::fmod(seconds, duration);
    if (t < 0.0) t += duration;
    return t;
  }
  return std::clamp(seconds, 0.0, duration);
}

glm::quat slerpShortest(const glm::quat& a, glm::quat const& bIn, float u) {
  glm::quat b = bIn;
  float cosine = glm::dot(a, b);
  if (cosine < 0.0f) {  // q and -q are one rotation: take the shorter arc
    b = -b;
    cosine = -cosine;
  }
  if (cosine > 0.9995f) return glm::normalize(a + u * (b - a));  // nearly parallel: lerp
  const float angle = std::acos(std::min(cosine, 1.0f));
  const float sine = std::sin(angle);
  return glm::normalize(a * (std::sin((1.0f - u) * angle) / sine) +
                        b * (std::sin(u * angle) / sine));
}

void sampleChannel(const AnimationChannel& channel, double t, std::span<float> out) {
  const size_t width = out.size();
  const std::vector<float>& times = channel.times;
  const bool cubic = channel.interpolation == Interpolation::cubicSpline;
  const size_t stride = cubic ? 3 * width : width;
  const size_t valueOffset = cubic ? width : 0;  // cubic keys: in-tangent, value, out-tangent
  auto value = [&](size_t key) { return channel.values.data() + key * stride + valueOffset; };
  const size_t keys = times.size();
  if (keys == 0) return;
  if (keys == 1 || t <= double(times.front())) {
    std::copy_n(value(0), width, out.begin());
    return;
  }
  if (t >= double(times.back())) {
    std::copy_n(value(keys - 1), width, out.begin());
    return;
  }
  const size_t k = keyBefore(times, t);
  const double interval = double(times[k + 1]) - double(times[k]);
  const float u = float((t - double(times[k])) / interval);
  switch (channel.interpolation) {
    case Interpolation::step:
      std::copy_n(value(k), width, out.begin());
      return;
    case Interpolation::linear:
      if (channel.path == AnimationPath::rotation) {
        const float* a = value(k);
        const float* b = value(k + 1);
        const glm::quat q =
            slerpShortest(glm::quat(a[3], a[0], a[1], a[2]), glm::quat(b[3], b[0], b[1], b[2]), u);
        out[0] = q.x, out[1] = q.y, out[2] = q.z, out[3] = q.w;
        return;
      }
      for (size_t i = 0; i < width; ++i) out[i] = value(k)[i] + u * (value(k + 1)[i] - value(k)[i]);
      return;
    case Interpolation::cubicSpline: {
      // glTF 2.0 Appendix C: Hermite with the tangents scaled by the key interval.
      const float u2 = u * u, u3 = u2 * u;
      const float h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u;
      const float h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
      const float d = float(interval);
      const float* v0 = value(k);
      const float* b0 = v0 + width;                                // out-tangent of key k
      const float* a1 = channel.values.data() + (k + 1) * stride;  // in-tangent of key k+1
      const float* v1 = value(k + 1);
      for (size_t i = 0; i < width; ++i) {
        out[i] = h00 * v0[i] + h10 * d * b0[i] + h01 * v1[i] + h11 * d * a1[i];
      }
      if (channel.path == AnimationPath::rotation) {
        glm::quat q(out[3], out[0], out[1], out[2]);
        const float length = glm::length(q);
        if (length > 0.0f && std::isfinite(length)) q = q / length;
        out[0] = q.x, out[1] = q.y, out[2] = q.z, out[3] = q.w;
      }
      return;
    }
  }
}

PosedNodes poseNodes(const Scene& scene, const Animation* clip, double clipSeconds) {
  const size_t n = scene.nodes.size();
  std::vector<Node> local = scene.nodes;
  PosedNodes posed;
  posed.world.resize(n);
  posed.moved.assign(n, 0);
  posed.weights.resize(n);
  if (clip != nullptr) {
    std::vector<uint32_t> targets;  // made on the first weights channel
    float buffer[4];
    for (const AnimationChannel& channel : clip->channels) {
      if (channel.node >= n) continue;
      Node& node = local[channel.node];
      switch (channel.path) {
        case AnimationPath::translation:
          sampleChannel(channel, clipSeconds, std::span<float>(buffer, 3));
          node.translation = {buffer[0], buffer[1], buffer[2]};
          break;
        case AnimationPath::scale:
          sampleChannel(channel, clipSeconds, std::span<float>(buffer, 3));
          node.scale = {buffer[0], buffer[1], buffer[2]};
          break;
        case AnimationPath::rotation:
          sampleChannel(channel, clipSeconds, std::span<float>(buffer, 4));
          node.rotation = glm::quat(buffer[3], buffer[0], buffer[1], buffer[2]);
          break;
        case AnimationPath::weights: {
          if (targets.empty()) targets = targetCounts(scene);
          if (targets[channel.node] == 0) continue;
          std::vector<float>& w = posed.weights[channel.node];
          w.assign(targets[channel.node], 0.0f);
          sampleChannel(channel, clipSeconds, w);
          continue;  // weights do not move the node
        }
      }
      posed.moved[channel.node] = 1;
    }
  }
  for (size_t i = 0; i < n; ++i) {
    const int32_t parent = scene.nodes[i].parent;
    const glm::mat4 own = localMatrix(local[i]);
    if (parent >= 0 && size_t(parent) < i) {
      posed.world[i] = posed.world[size_t(parent)] * own;
      posed.moved[i] = posed.moved[i] | posed.moved[size_t(parent)];
    } else {
      posed.world[i] = own;
    }
  }
  return posed;
}

std::vector<PosedInstance> poseInstances(const Scene& scene, int clip, double seconds, bool loop) {
  const Animation* animation = clip >= 0 && size_t(clip) < scene.animations.size()
                                   ? &scene.animations[size_t(clip)]
                                   : nullptr;
  const PosedNodes nodes =
      poseNodes(scene, animation, animation != nullptr ? clipTime(*animation, seconds, loop) : 0.0);
  std::vector<PosedInstance> out;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& instance = scene.instances[i];
    if (instance.mesh >= scene.meshes.size()) continue;
    const Mesh& mesh = scene.meshes[instance.mesh];
    PosedInstance posed;
    posed.instance = uint32_t(i);
    bool any = false;
    if (instance.skin >= 0 && size_t(instance.skin) < scene.skins.size() && mesh.skinned()) {
      const Skin& skin = scene.skins[size_t(instance.skin)];
      posed.joints.resize(skin.joints.size());
      for (size_t j = 0; j < skin.joints.size(); ++j) {
        const uint32_t node = skin.joints[j];
        posed.joints[j] =
            (node < nodes.world.size() ? nodes.world[node] : glm::mat4(1.0f)) * skin.inverseBind[j];
        // Finite keys can still overflow (a scale of 1e30 on a scale of 1e30): such a joint
        // stays at its bind pose rather than sending infinities to the GPU.
        if (!finite(posed.joints[j])) posed.joints[j] = glm::mat4(1.0f);
      }
      any = true;
    } else if (instance.node >= 0 && size_t(instance.node) < nodes.moved.size() &&
               nodes.moved[size_t(instance.node)] && finite(nodes.world[size_t(instance.node)])) {
      posed.transform = nodes.world[size_t(instance.node)];
      any = true;
    }
    if (mesh.morphed()) {
      const std::vector<float>* animatedWeights =
          instance.node >= 0 && size_t(instance.node) < nodes.weights.size() &&
                  !nodes.weights[size_t(instance.node)].empty()
              ? &nodes.weights[size_t(instance.node)]
              : nullptr;
      posed.morphWeights = animatedWeights != nullptr ? *animatedWeights : mesh.morphWeights;
      posed.morphWeights.resize(mesh.morphTargets.size(), 0.0f);
      for (float& w : posed.morphWeights) {
        if (!std::isfinite(w)) w = 0.0f;
      }
      any = true;
    }
    if (any) out.push_back(std::move(posed));
  }
  return out;
}

bool animated(const Scene& scene) {
  if (!scene.animations.empty() || !scene.skins.empty()) return true;
  return std::any_of(scene.meshes.begin(), scene.meshes.end(),
                     [](const Mesh& m) { return m.morphed() || m.skinned(); });
}

int findClip(const Scene& scene, std::string_view name) {
  uint32_t index = 0;
  const auto [end, ec] = std::from_chars(name.data(), name.data() + name.size(), index);
  if (!name.empty() && ec == std::errc() && end == name.data() + name.size()) {
    return index < scene.animations.size() ? int(index) : -1;
  }
  for (size_t i = 0; i < scene.animations.size(); ++i) {
    if (scene.animations[i].name == name) return int(i);
  }
  return -1;
}

Bounds posedBounds(const Scene& scene, int clip, double seconds, bool loop) {
  std::vector<const PosedInstance*> posedOf(scene.instances.size(), nullptr);
  const std::vector<PosedInstance> posed = poseInstances(scene, clip, seconds, loop);
  for (const PosedInstance& p : posed) posedOf[p.instance] = &p;
  Bounds out;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& instance = scene.instances[i];
    if (instance.mesh >= scene.meshes.size()) continue;
    const Mesh& mesh = scene.meshes[instance.mesh];
    const PosedInstance* p = posedOf[i];
    Bounds b;
    if (p != nullptr && (!p->joints.empty() || !p->morphWeights.empty())) {
      const glm::mat4 transform = p->transform.value_or(instance.transform);
      for (const Vertex& v : poseVertices(mesh, p->joints, p->morphWeights)) {
        b.extend(glm::vec3(transform * glm::vec4(v.position, 1.0f)));
      }
    } else {
      b = transformedBounds(mesh,
                            p != nullptr && p->transform ? *p->transform : instance.transform);
    }
    if (!b.empty()) {
      out.extend(b.min);
      out.extend(b.max);
    }
  }
  return out;
}

std::vector<Vertex> poseVertices(const Mesh& mesh, std::span<const glm::mat4> joints,
                                 std::span<const float> morphWeights) {
  std::vector<Vertex> out = mesh.vertices;
  const std::span<const float> weights =
      morphWeights.empty() ? std::span<const float>(mesh.morphWeights) : morphWeights;
  for (size_t t = 0; t < mesh.morphTargets.size() && t < weights.size(); ++t) {
    const MorphTarget& target = mesh.morphTargets[t];
    const float w = weights[t];
    if (w == 0.0f) continue;
    for (size_t v = 0; v < out.size(); ++v) {
      if (!target.positions.empty()) out[v].position += w * target.positions[v];
      if (!target.normals.empty()) out[v].normal += w * target.normals[v];
      if (!target.tangents.empty()) out[v].tangent += glm::vec4(w * target.tangents[v], 0.0f);
    }
  }
  const bool skinned =
      !joints.empty() && mesh.joints.size() == out.size() && mesh.weights.size() == out.size();
  for (size_t v = 0; v < out.size(); ++v) {
    Vertex& vertex = out[v];
    if (skinned) {
      const glm::uvec4 j = mesh.joints[v];
      const glm::vec4 w = mesh.weights[v];
      glm::mat4 m(0.0f);
      for (int k = 0; k < 4; ++k) {
        if (w[k] != 0.0f && j[k] < joints.size()) m += w[k] * joints[j[k]];
      }
      vertex.position = glm::vec3(m * glm::vec4(vertex.position, 1.0f));
      vertex.normal = glm::mat3(m) * vertex.normal;
      vertex.tangent = glm::vec4(glm::mat3(m) * glm::vec3(vertex.tangent), vertex.tangent.w);
    }
    const float length = glm::length(vertex.normal);
    if (length > 0.0f && std::isfinite(length)) vertex.normal /= length;
    const float tangentLength = glm::length(glm::vec3(vertex.tangent));
    if (vertex.tangent.w != 0.0f && tangentLength > 0.0f && std::isfinite(tangentLength)) {
      vertex.tangent = glm::vec4(glm::vec3(vertex.tangent) / tangentLength, vertex.tangent.w);
    }
  }
  return out;
}

}  // namespace myriad::scene
