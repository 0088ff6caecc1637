#include "scene/gltf_animation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

#include <nlohmann/json.hpp>

#include "scene/animation.h"

namespace myriad::scene::detail {

namespace {

using nlohmann::json;

// Why a sampler cannot be read here: the loader then keeps Assimp's animations (not hostile, just
// beyond this reader: sparse accessors, an unreadable buffer).
struct Unreadable {};
// The file's animation data is broken or hostile: the model is refused with this.
struct Refused {
  std::string reason;
};

std::optional<std::string> base64Decode(std::string_view text) {
  std::string out;
  out.reserve(text.size() / 4 * 3);
  uint32_t bits = 0;
  int count = 0;
  for (char c : text) {
    int value;
    if (c >= 'A' && c <= 'Z')
      value = c - 'A';
    else if (c >= 'a' && c <= 'z')
      value = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      value = c - '0' + 52;
    else if (c == '+' || c == '-')
      value = 62;
    else if (c == '/' || c == '_')
      value = 63;
    else if (c == '=')
      break;
    else
      return std::nullopt;
    bits = (bits << 6) | uint32_t(value);
    if (++count == 4) {
      out += char(bits >> 16), out += char((bits >> 8) & 0xFF), out += char(bits & 0xFF);
      bits = 0, count = 0;
    }
  }
  if (count == 2) out += char(bits >> 4);
  if (count == 3) out += char(bits >> 10), out += char((bits >> 2) & 0xFF);
  return out;
}

size_t componentBytes(int type) {
  switch (type) {
    case 5120:
    case 5121:
      return 1;
    case 5122:
    case 5123:
      return 2;
    case 5125:
    case 5126:
      return 4;
    default:
      return 0;
  }
}

size_t components(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  return 0;
}

class Reader {
 public:
  Reader(const GltfFile& file, const json& root, std::string_view bin)
      : file_(file), root_(root), bin_(bin) {}

  // Accessor `index` as floats (normalized integers to [0, 1] or [-1, 1] as glTF says),
  // counting them against `budget` (floats left) before reading any.
  std::vector<float> floats(const json& index, size_t& budget, size_t& count, size_t& width) {
    const json& accessors = root_.value("accessors", json::array());
    if (!index.is_number_unsigned() || index.get<size_t>() >= accessors.size())
      throw Refused{"an animation sampler names an accessor that does not exist"};
    const json& a = accessors[index.get<size_t>()];
    if (a.contains("sparse") || !a.contains("bufferView")) throw Unreadable{};
    const int type = a.value("componentType", 0);
    const size_t bytes = componentBytes(type);
    width = components(a.value("type", std::string()));
    count = a.value("count", size_t(0));
    if (bytes == 0 || width == 0 || type == 5125)
      throw Refused{"an animation accessor has a type glTF does not allow there"};
    if (count > kMaxAnimationFloats || count * width > budget) {
      throw Refused{"its animation keys hold more than " + std::to_string(kMaxAnimationFloats) +
                    " numbers"};
    }
    budget -= count * width;
    const std::string_view buffer = view(a.at("bufferView"));
    const json& v = root_.at("bufferViews").at(a.at("bufferView").get<size_t>());
    const size_t element = bytes * width;
    const size_t stride =
        v.value("byteStride", size_t(0)) != 0 ? v.value("byteStride", size_t(0)) : element;
    const size_t offset = a.value("byteOffset", size_t(0));
    if (count > 0) {
      const size_t available = offset <= buffer.size() ? buffer.size() - offset : 0;
      if (offset > buffer.size() || stride < element || available < element ||
          (count - 1) > (available - element) / stride) {
        throw Refused{"an animation accessor reaches past its buffer"};
      }
    }
    const bool normalized = a.value("normalized", false);
    std::vector<float> out(count * width);
    for (size_t i = 0; i < count; ++i) {
      const char* at = buffer.data() + offset + i * stride;
      for (size_t c = 0; c < width; ++c) {
        const char* p = at + c * bytes;
        float value = 0.0f;
        switch (type) {
          case 5126:
            std::memcpy(&value, p, 4);
            break;
          case 5120: {
            int8_t x;
            std::memcpy(&x, p, 1);
            value = normalized ? std::max(x / 127.0f, -1.0f) : x;
            break;
          }
          case 5121: {
            uint8_t x;
            std::memcpy(&x, p, 1);
            value = normalized ? x / 255.0f : x;
            break;
          }
          case 5122: {
            int16_t x;
            std::memcpy(&x, p, 2);
            value = normalized ? std::max(x / 32767.0f, -1.0f) : x;
            break;
          }
          case 5123: {
            uint16_t x;
            std::memcpy(&x, p, 2);
            value = normalized ? x / 65535.0f : x;
            break;
          }
        }
        out[i * width + c] = value;
      }
    }
    return out;
  }

 private:
  std::string_view view(const json& index) {
    const json& views = root_.value("bufferViews", json::array());
    if (!index.is_number_unsigned() || index.get<size_t>() >= views.size())
      throw Refused{"an animation accessor names a buffer view that does not exist"};
    const json& v = views[index.get<size_t>()];
    const std::string_view whole = buffer(v.value("buffer", size_t(SIZE_MAX)));
    const size_t offset = v.value("byteOffset", size_t(0)),
                 length = v.value("byteLength", size_t(0));
    if (offset > whole.size() || length > whole.size() - offset)
      throw Refused{"an animation buffer view reaches past its buffer"};
    return whole.substr(offset, length);
  }

  std::string_view buffer(size_t index) {
    if (auto it = buffers_.find(index); it != buffers_.end()) return it->second;
    const json& buffers = root_.value("buffers", json::array());
    if (index >= buffers.size())
      throw Refused{"an animation buffer view names a buffer that does not exist"};
    const json& b = buffers[index];
    std::string bytes;
    if (!b.contains("uri")) {
      if (!file_.binary || index != 0) throw Unreadable{};
      bytes = std::string(bin_);
    } else {
      const std::string uri = b["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) {
        const size_t comma = uri.find(',');
        if (comma == std::string::npos || uri.substr(0, comma).find(";base64") == std::string::npos)
          throw Unreadable{};
        std::optional<std::string> decoded = base64Decode(std::string_view(uri).substr(comma + 1));
        if (!decoded) throw Unreadable{};
        bytes = std::move(*decoded);
      } else {
        std::optional<std::string> read = file_.read ? file_.read(uri) : std::nullopt;
        if (!read) throw Unreadable{};
        bytes = std::move(*read);
      }
    }
    const size_t declared = b.value("byteLength", size_t(0));
    if (bytes.size() > declared) bytes.resize(declared);
    return buffers_.emplace(index, std::move(bytes)).first->second;
  }

  const GltfFile& file_;
  const json& root_;
  std::string_view bin_;
  std::map<size_t, std::string> buffers_;
};

// Per glTF node, its index in Scene::nodes (-1: not in the scene), following Assimp's walk.
std::optional<std::vector<int32_t>> mapNodes(const json& root, const Scene& scene) {
  const json& nodes = root.value("nodes", json::array());
  const json& scenes = root.value("scenes", json::array());
  const size_t chosen = root.value("scene", size_t(0));
  if (!nodes.is_array() || chosen >= scenes.size()) return std::nullopt;
  const json& roots = scenes[chosen].value("nodes", json::array());
  std::vector<int32_t> map(nodes.size(), -1);
  int32_t next = roots.size() > 1 ? 1 : 0;  // Assimp's "ROOT" above several roots
  std::vector<size_t> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
    if (!it->is_number_unsigned() || it->get<size_t>() >= nodes.size()) return std::nullopt;
    stack.push_back(it->get<size_t>());
  }
  while (!stack.empty()) {
    const size_t n = stack.back();
    stack.pop_back();
    if (map[n] >= 0 || size_t(next) >= scene.nodes.size()) return std::nullopt;  // a DAG, or more
    const json& node = nodes[n];
    const std::string name = node.value("name", std::string());
    if (scene.nodes[size_t(next)].name !=
        (name.empty() ? "nodes[" + std::to_string(n) + "]" : name)) {
      return std::nullopt;
    }
    map[n] = next++;
    const json& children = node.value("children", json::array());
    for (auto it = children.rbegin(); it != children.rend(); ++it) {
      if (!it->is_number_unsigned() || it->get<size_t>() >= nodes.size()) return std::nullopt;
      stack.push_back(it->get<size_t>());
    }
  }
  if (size_t(next) != scene.nodes.size()) return std::nullopt;
  return map;
}

}  // namespace

std::optional<std::string> readGltfAnimations(const GltfFile& file, Scene& scene) {
  std::string_view text = file.bytes;
  std::string_view bin;
  if (file.binary) {
    // GLB: 12-byte header, then chunks (length, type, data): JSON first, then BIN.
    auto u32 = [&](size_t at) {
      uint32_t v = 0;
      if (at + 4 <= file.bytes.size()) std::memcpy(&v, file.bytes.data() + at, 4);
      return v;
    };
    if (file.bytes.size() < 20 || u32(0) != 0x46546C67u) return std::nullopt;
    const size_t jsonLength = u32(12);
    if (u32(16) != 0x4E4F534Au || jsonLength > file.bytes.size() - 20) return std::nullopt;
    text = file.bytes.substr(20, jsonLength);
    const size_t binAt = 20 + jsonLength;
    if (binAt + 8 <= file.bytes.size() && u32(binAt + 4) == 0x004E4942u) {
      bin =
          file.bytes.substr(binAt + 8, std::min<size_t>(u32(binAt), file.bytes.size() - binAt - 8));
    }
  }
  const json root = json::parse(text, nullptr, false);
  if (root.is_discarded() || !root.is_object()) return std::nullopt;
  const json& animations = root.value("animations", json::array());
  if (!animations.is_array() || animations.empty()) return std::nullopt;
  if (animations.size() > kMaxAnimations) {
    return "it has " + std::to_string(animations.size()) + " animations (at most " +
           std::to_string(kMaxAnimations) + ")";
  }
  const std::optional<std::vector<int32_t>> nodeMap = mapNodes(root, scene);
  if (!nodeMap) return std::nullopt;
  std::vector<uint32_t> targets(scene.nodes.size(), 0);
  for (const Instance& instance : scene.instances) {
    if (instance.node >= 0 && instance.mesh < scene.meshes.size() &&
        targets[size_t(instance.node)] == 0) {
      targets[size_t(instance.node)] = uint32_t(scene.meshes[instance.mesh].morphTargets.size());
    }
  }
  Reader reader(file, root, bin);
  std::vector<Animation> out;
  size_t budget = kMaxAnimationFloats, channelCount = 0;
  try {
    for (size_t a = 0; a < animations.size(); ++a) {
      const json& anim = animations[a];
      Animation animation;
      animation.name = anim.value("name", std::string());
      if (animation.name.empty()) animation.name = "animation " + std::to_string(a);
      const json& samplers = anim.value("samplers", json::array());
      for (const json& ch : anim.value("channels", json::array())) {
        if (++channelCount > kMaxAnimationChannels) {
          throw Refused{"its animations have more than " + std::to_string(kMaxAnimationChannels) +
                        " channels"};
        }
        const json& target = ch.value("target", json::object());
        const size_t node = target.value("node", size_t(SIZE_MAX));
        const std::string path = target.value("path", std::string());
        const size_t s = ch.value("sampler", size_t(SIZE_MAX));
        if (s >= samplers.size())
          throw Refused{"an animation channel names a sampler that does not exist"};
        if (node >= nodeMap->size() || (*nodeMap)[node] < 0) continue;  // not in the scene
        AnimationChannel channel;
        channel.node = uint32_t((*nodeMap)[node]);
        if (path == "translation")
          channel.path = AnimationPath::translation;
        else if (path == "rotation")
          channel.path = AnimationPath::rotation;
        else if (path == "scale")
          channel.path = AnimationPath::scale;
        else if (path == "weights")
          channel.path = AnimationPath::weights;
        else
          continue;  // an extension's path
        const json& sampler = samplers[s];
        const std::string interpolation = sampler.value("interpolation", std::string("LINEAR"));
        channel.interpolation = interpolation == "STEP"          ? Interpolation::step
                                : interpolation == "CUBICSPLINE" ? Interpolation::cubicSpline
                                                                 : Interpolation::linear;
        size_t keys = 0, inWidth = 0, valueCount = 0, outWidth = 0;
        channel.times = reader.floats(sampler.value("input", json()), budget, keys, inWidth);
        channel.values =
            reader.floats(sampler.value("output", json()), budget, valueCount, outWidth);
        if (inWidth != 1 || keys == 0)
          throw Refused{"animation '" + animation.name.substr(0, 64) +
                        "' has a sampler without scalar key times"};
        const size_t width = keyWidth(
            channel.path, channel.path == AnimationPath::weights ? targets[channel.node] : 0);
        if (channel.path == AnimationPath::weights && width == 0)
          continue;  // no morph targets there
        const size_t perKey = (channel.interpolation == Interpolation::cubicSpline ? 3 : 1) * width;
        if (channel.values.size() != perKey * keys) {
          throw Refused{"animation '" + animation.name.substr(0, 64) +
                        "' has a sampler whose values do not match its keys"};
        }
        for (size_t k = 0; k < keys; ++k) {
          const float t = channel.times[k];
          if (!std::isfinite(t))
            throw Refused{"animation '" + animation.name.substr(0, 64) +
                          "' has a non-finite key (NaN or infinite)"};
          if (t < 0.0f || t > kMaxAnimationSeconds || (k > 0 && !(t > channel.times[k - 1]))) {
            throw Refused{"animation '" + animation.name.substr(0, 64) +
                          "' has key times that are negative, too late or do not increase"};
          }
        }
        for (float v : channel.values) {
          if (!std::isfinite(v))
            throw Refused{"animation '" + animation.name.substr(0, 64) +
                          "' has a non-finite key (NaN or infinite)"};
        }
        animation.duration = std::max(animation.duration, channel.times.back());
        animation.channels.push_back(std::move(channel));
      }
      if (!animation.channels.empty()) out.push_back(std::move(animation));
    }
  } catch (const Unreadable&) {
    return std::nullopt;
  } catch (const Refused& refused) {
    return refused.reason;
  } catch (const json::exception&) {
    return std::nullopt;  // a member of an unexpected type: Assimp's reading stands
  }
  scene.animations = std::move(out);
  return std::nullopt;
}

}  // namespace myriad::scene::detail
