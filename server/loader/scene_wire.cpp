#include "loader/scene_wire.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "scene/animation.h"
#include "scene/image_decode.h"

namespace myriad::loader {

namespace {

constexpr char kMagic[4] = {'M', 'Y', 'R', 'W'};
constexpr size_t kHeaderBytes = 4 + 4 * 6 + 8;
// The smallest each element can be on the wire: what a count is checked against before any
// allocation, so a forged count cannot make the parent reserve memory the bytes do not back.
constexpr size_t kTextureRefBytes = 4 + 6 + 5 * 4 + 4;
constexpr size_t kMinMaterialBytes = 4 + 12 * 4 + 2 + 4 + scene::Material::kTextureSlots * kTextureRefBytes;
constexpr size_t kMinMeshBytes = 4 + 4 + 4;
constexpr size_t kVertexBytes = 16 * 4;
constexpr size_t kMinImageBytes = 4 + 4 + 4 + 4;
constexpr size_t kInstanceBytes = 2 * 4 + 16 * 4;
constexpr size_t kLightBytes = 16 * 4;
constexpr size_t kMinCameraBytes = 4 + 4 + 4 * 4 + 9 * 4;
constexpr uint32_t kMaxWireCameras = 65536;
constexpr uint32_t kMaxWireIgnoredExtensions = 64;
constexpr size_t kNodeBytes = 4 + 4 + 10 * 4;  // empty name, parent, TRS
constexpr size_t kMinSkinBytes = 4 + 4;
constexpr size_t kJointBytes = 4 + 16 * 4;
constexpr size_t kSkinVertexBytes = 8 * 4;
constexpr size_t kMinMorphTargetBytes = 4 + 1 + 4;
constexpr size_t kMinAnimationBytes = 4 + 4 + 4;
constexpr size_t kMinChannelBytes = 4 + 2 + 4 + 4;

static_assert(std::endian::native == std::endian::little, "the wire format is little-endian");

class Writer {
 public:
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void put(const glm::vec2& v) { put(v.x), put(v.y); }
  void put(const glm::vec3& v) { put(v.x), put(v.y), put(v.z); }
  void put(const glm::vec4& v) { put(v.x), put(v.y), put(v.z), put(v.w); }
  void put(const glm::mat4& m) {
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) put(m[c][r]);
    }
  }
  void putName(const std::string& name) {
    const size_t length = std::min<size_t>(name.size(), kMaxWireNameBytes);
    put(uint32_t(length));
    bytes_.append(name.data(), length);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

[[noreturn]] void reject(const std::string& what) { throw SceneWireError(what); }

template <typename T>
void putArray(Writer& w, const std::vector<T>& values) {
  static_assert(std::is_trivially_copyable_v<T>);
  const size_t at = w.bytes().size();
  w.bytes().resize(at + values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(w.bytes().data() + at, values.data(), values.size() * sizeof(T));
}

// The node tree, every instance's node and skin, skins, each mesh's joints, weights and morph
// targets, and the animations (after the images, see scene_wire.h).
void encodeAnimation(const scene::Scene& scene, Writer& w) {
  w.put(uint32_t(scene.nodes.size()));
  for (const scene::Node& n : scene.nodes) {
    w.putName(n.name);
    w.put(n.parent), w.put(n.translation);
    w.put(n.rotation.x), w.put(n.rotation.y), w.put(n.rotation.z), w.put(n.rotation.w);
    w.put(n.scale);
  }
  for (const scene::Instance& i : scene.instances) w.put(i.node), w.put(i.skin);
  w.put(uint32_t(scene.skins.size()));
  for (const scene::Skin& skin : scene.skins) {
    w.putName(skin.name);
    w.put(uint32_t(skin.joints.size()));
    for (size_t j = 0; j < skin.joints.size(); ++j)
      w.put(skin.joints[j]), w.put(skin.inverseBind[j]);
  }
  for (const scene::Mesh& mesh : scene.meshes) {
    w.put(uint32_t(mesh.skinned() ? 1 : 0));
    if (mesh.skinned()) {
      for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        w.put(mesh.joints[v].x), w.put(mesh.joints[v].y), w.put(mesh.joints[v].z),
            w.put(mesh.joints[v].w);
        w.put(mesh.weights[v]);
      }
    }
    w.put(uint32_t(mesh.morphTargets.size()));
    for (size_t t = 0; t < mesh.morphTargets.size(); ++t) {
      const scene::MorphTarget& target = mesh.morphTargets[t];
      w.putName(target.name);
      w.put(uint8_t((target.positions.empty() ? 0 : 1) | (target.normals.empty() ? 0 : 2) |
                    (target.tangents.empty() ? 0 : 4)));
      putArray(w, target.positions), putArray(w, target.normals), putArray(w, target.tangents);
      w.put(t < mesh.morphWeights.size() ? mesh.morphWeights[t] : 0.0f);
    }
  }
  w.put(uint32_t(scene.animations.size()));
  for (const scene::Animation& a : scene.animations) {
    w.putName(a.name);
    w.put(a.duration);
    w.put(uint32_t(a.channels.size()));
    for (const scene::AnimationChannel& c : a.channels) {
      w.put(c.node), w.put(uint8_t(c.path)), w.put(uint8_t(c.interpolation));
      w.put(uint32_t(c.times.size())), putArray(w, c.times);
      w.put(uint32_t(c.values.size())), putArray(w, c.values);
    }
  }
}

}  // namespace

std::string cleanText(std::string_view raw) {
  std::string out;
  out.reserve(raw.size());
  size_t i = 0;
  while (i < raw.size()) {
    const auto c = static_cast<unsigned char>(raw[i]);
    size_t length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    bool valid = length != 0 && i + length <= raw.size();
    for (size_t k = 1; valid && k < length; ++k) {
      valid = (static_cast<unsigned char>(raw[i + k]) & 0xC0) == 0x80;
    }
    if (valid && length > 1) {
      // Overlong forms, surrogates and code points past U+10FFFF are not UTF-8 either.
      uint32_t cp = c & (0xFF >> (length + 1));
      for (size_t k = 1; k < length; ++k) cp = (cp << 6) | (raw[i + k] & 0x3F);
      const uint32_t minimum[] = {0, 0, 0x80, 0x800, 0x10000};
      valid = cp >= minimum[length] && cp <= 0x10FFFF && (cp < 0xD800 || cp > 0xDFFF);
    }
    if (!valid) {
      out += '?';
      ++i;
    } else if (length == 1 && (c < 0x20 || c == 0x7F)) {
      out += ' ';
      ++i;
    } else {
      out.append(raw.substr(i, length));
      i += length;
    }
  }
  return out;
}

namespace {

class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}

  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  float finite(const char* what) {
    const float value = get<float>();
    if (!std::isfinite(value)) reject(std::string("a non-finite number in ") + what);
    return value;
  }
  float inRange(const char* what, float low, float high) {
    const float value = finite(what);
    if (value < low || value > high) reject(std::string(what) + " out of range");
    return value;
  }
  glm::vec2 vec2(const char* what) { return {finite(what), finite(what)}; }
  glm::vec3 vec3(const char* what) {
    const float x = finite(what), y = finite(what), z = finite(what);
    return {x, y, z};
  }
  // Three finite numbers each in [0, 1] (a colour): else "<what> out of range".
  glm::vec3 unitVec3(const char* what) {
    const glm::vec3 v = vec3(what);
    if (glm::any(glm::lessThan(v, glm::vec3(0.0f))) || glm::any(glm::greaterThan(v, glm::vec3(1.0f)))) {
      reject(std::string(what) + " out of range");
    }
    return v;
  }
  glm::vec4 vec4(const char* what) {
    const float x = finite(what), y = finite(what), z = finite(what), w = finite(what);
    return {x, y, z, w};
  }
  // One byte that must be below `limit` (an enum or a bool).
  uint8_t small(const char* what, uint8_t limit) {
    const auto value = get<uint8_t>();
    if (value >= limit) reject(std::string(what) + " out of range");
    return value;
  }
  std::string_view take(size_t n) {
    need(n);
    const std::string_view out = bytes_.substr(at_, n);
    at_ += n;
    return out;
  }
  glm::mat4 mat4(const char* what) {
    glm::mat4 m;
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m[c][r] = finite(what);
    }
    return m;
  }
  std::string name() {
    const uint32_t length = get<uint32_t>();
    if (length > kMaxWireNameBytes) reject("a name longer than the limit");
    need(length);
    std::string text = cleanText(bytes_.substr(at_, length));
    at_ += length;
    return text;
  }
  // A count of elements at least `minBytes` each, checked against the bytes that remain.
  uint32_t count(uint32_t value, size_t minBytes, const char* what) {
    if (uint64_t(value) * minBytes > remaining()) {
      reject(std::string("more ") + what + " than the bytes can hold");
    }
    return value;
  }
  size_t remaining() const { return bytes_.size() - at_; }
  // `n` floats, each finite (the count checked against the bytes first).
  std::vector<float> floats(uint32_t n, const char* what) {
    count(n, 4, what);
    std::vector<float> out(n);
    for (float& v : out) v = finite(what);
    return out;
  }

 private:
  void need(size_t n) {
    if (n > remaining()) reject("truncated");
  }

  std::string_view bytes_;
  size_t at_ = 0;
};

}  // namespace

namespace {

// encodeAnimation's counterpart: every count against the bytes left, then the rules of
// scene::checkAnimationData (indices, parents first: no cycle, limits, finite keys).
void decodeAnimation(Reader& r, scene::Scene& scene) {
  const uint32_t nodeCount = r.count(r.get<uint32_t>(), kNodeBytes, "nodes");
  if (nodeCount > scene::kMaxNodes) reject("more nodes than the limit");
  scene.nodes.resize(nodeCount);
  for (scene::Node& n : scene.nodes) {
    n.name = r.name();
    n.parent = r.get<int32_t>();
    n.translation = r.vec3("a node's translation");
    const glm::vec4 q = r.vec4("a node's rotation");
    n.rotation = glm::quat(q.w, q.x, q.y, q.z);
    if (std::abs(glm::length(q) - 1.0f) > 1e-3f)
      reject("a node rotation that is not a unit quaternion");
    n.scale = r.vec3("a node's scale");
  }
  for (scene::Instance& i : scene.instances) {
    i.node = r.get<int32_t>();
    i.skin = r.get<int32_t>();
  }
  const uint32_t skinCount = r.count(r.get<uint32_t>(), kMinSkinBytes, "skins");
  if (skinCount > scene::kMaxSkins) reject("more skins than the limit");
  scene.skins.resize(skinCount);
  for (scene::Skin& skin : scene.skins) {
    skin.name = r.name();
    const uint32_t joints = r.count(r.get<uint32_t>(), kJointBytes, "joints");
    if (joints > scene::kMaxJointsPerSkin) reject("a skin with more joints than the limit");
    for (uint32_t j = 0; j < joints; ++j) {
      skin.joints.push_back(r.get<uint32_t>());
      skin.inverseBind.push_back(r.mat4("an inverse bind matrix"));
    }
  }
  size_t morphVectors = 0;
  for (scene::Mesh& mesh : scene.meshes) {
    const uint32_t skinned = r.get<uint32_t>();
    if (skinned > 1) reject("a mesh's skinned flag out of range");
    const size_t n = mesh.vertices.size();
    if (skinned == 1) {
      if (uint64_t(n) * kSkinVertexBytes > r.remaining())
        reject("more joint weights than the bytes can hold");
      mesh.joints.resize(n);
      mesh.weights.resize(n);
      for (size_t v = 0; v < n; ++v) {
        const uint32_t a = r.get<uint32_t>(), b = r.get<uint32_t>(), c = r.get<uint32_t>(),
                       d = r.get<uint32_t>();
        mesh.joints[v] = {a, b, c, d};
        mesh.weights[v] = r.vec4("a skin weight");
      }
    }
    const uint32_t targets = r.count(r.get<uint32_t>(), kMinMorphTargetBytes, "morph targets");
    if (targets > scene::kMaxMorphTargets) reject("a mesh with more morph targets than the limit");
    for (uint32_t t = 0; t < targets; ++t) {
      scene::MorphTarget target;
      target.name = r.name();
      const uint8_t flags = r.small("a morph target's attributes", 8);
      for (int bit = 0; bit < 3; ++bit) {
        if (!(flags & (1 << bit))) continue;
        morphVectors += n;
        if (morphVectors > scene::kMaxMorphVectors)
          reject("more morph displacements than the limit");
        if (uint64_t(n) * 12 > r.remaining())
          reject("more morph displacements than the bytes can hold");
        std::vector<glm::vec3>& list = bit == 0   ? target.positions
                                       : bit == 1 ? target.normals
                                                  : target.tangents;
        list.resize(n);
        for (glm::vec3& v : list) v = r.vec3("a morph displacement");
      }
      mesh.morphTargets.push_back(std::move(target));
      mesh.morphWeights.push_back(r.finite("a morph weight"));
    }
  }
  const uint32_t animationCount = r.count(r.get<uint32_t>(), kMinAnimationBytes, "animations");
  if (animationCount > scene::kMaxAnimations) reject("more animations than the limit");
  size_t channels = 0, floats = 0;
  scene.animations.resize(animationCount);
  for (scene::Animation& a : scene.animations) {
    a.name = r.name();
    a.duration = r.finite("an animation's duration");
    const uint32_t channelCount = r.count(r.get<uint32_t>(), kMinChannelBytes, "channels");
    channels += channelCount;
    if (channels > scene::kMaxAnimationChannels) reject("more animation channels than the limit");
    a.channels.resize(channelCount);
    for (scene::AnimationChannel& c : a.channels) {
      c.node = r.get<uint32_t>();
      c.path = scene::AnimationPath(r.small("an animation path", 4));
      c.interpolation = scene::Interpolation(r.small("an interpolation", 3));
      const uint32_t keys = r.get<uint32_t>();
      floats += keys;
      if (floats > scene::kMaxAnimationFloats) reject("more animation keys than the limit");
      c.times = r.floats(keys, "an animation key time");
      const uint32_t values = r.get<uint32_t>();
      floats += values;
      if (floats > scene::kMaxAnimationFloats) reject("more animation keys than the limit");
      c.values = r.floats(values, "an animation key value");
    }
  }
  if (const std::optional<std::string> problem = scene::checkAnimationData(scene)) reject(*problem);
}

}  // namespace

std::string encodeScene(const scene::Scene& scene) {
  Writer w;
  w.bytes().append(kMagic, 4);
  w.put(kSceneWireVersion);
  w.put(uint32_t(scene.meshes.size()));
  w.put(uint32_t(scene.materials.size()));
  w.put(uint32_t(scene.instances.size()));
  w.put(uint32_t(scene.lights.size()));
  w.put(uint32_t(scene.images.size()));
  w.put(uint64_t(0));  // body size, filled in below

  w.put(scene.sun.direction), w.put(scene.sun.color), w.put(scene.sun.intensity);
  w.put(scene.ambient), w.put(scene.background);
  const scene::Camera& c = scene.camera;
  w.put(c.eye), w.put(c.target), w.put(c.up);
  w.put(c.fovYDegrees), w.put(c.nearPlane), w.put(c.farPlane);

  for (const scene::Material& m : scene.materials) {
    w.putName(m.name);
    w.put(m.baseColor), w.put(m.metallic), w.put(m.roughness);
    w.put(m.alpha), w.put(m.emissive), w.put(m.emissiveStrength), w.put(m.normalScale);
    w.put(m.occlusionStrength), w.put(uint8_t(m.alphaMode)), w.put(m.alphaCutoff);
    w.put(uint8_t(m.doubleSided)), w.put(uint8_t(m.unlit)), w.put(m.ior), w.put(m.specular);
    w.put(m.clearcoat), w.put(m.clearcoatRoughness), w.put(m.sheenColor), w.put(m.sheenRoughness);
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
      const scene::TextureRef& t = m.texture(slot);
      w.put(t.image);
      w.put(uint8_t(t.sampler.wrapS)), w.put(uint8_t(t.sampler.wrapT));
      w.put(uint8_t(t.sampler.magFilter)), w.put(uint8_t(t.sampler.minFilter));
      w.put(uint8_t(t.sampler.mipmaps)), w.put(uint8_t(t.sampler.mipmapFilter));
      w.put(t.offset), w.put(t.scale), w.put(t.rotation), w.put(t.texCoord);
    }
  }
  for (const scene::Mesh& mesh : scene.meshes) {
    w.putName(mesh.name);
    w.put(uint32_t(mesh.vertices.size()));
    w.put(uint32_t(mesh.indices.size()));
    for (const scene::Vertex& v : mesh.vertices) {
      w.put(v.position), w.put(v.normal), w.put(v.uv), w.put(v.tangent), w.put(v.color);
    }
    const size_t at = w.bytes().size();
    w.bytes().resize(at + mesh.indices.size() * sizeof(uint32_t));
    std::memcpy(w.bytes().data() + at, mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t));
  }
  for (const scene::Instance& i : scene.instances) {
    w.put(i.mesh), w.put(i.material), w.put(i.transform);
  }
  for (const scene::PointLight& l : scene.lights) {
    w.put(l.position), w.put(l.radius), w.put(l.color), w.put(l.intensity), w.put(l.falloff);
    w.put(uint32_t(l.type)), w.put(uint32_t(l.attenuation));
    w.put(l.direction), w.put(l.innerConeAngle), w.put(l.outerConeAngle);
  }
  w.put(uint32_t(scene.extraSuns.size()));
  for (const scene::Sun& sun : scene.extraSuns) {
    w.put(sun.direction), w.put(sun.color), w.put(sun.intensity);
  }
  w.put(scene.droppedSuns);
  w.put(uint32_t(scene.ignoredExtensions.size()));
  for (const std::string& name : scene.ignoredExtensions) w.putName(name);
  w.put(uint32_t(scene.cameras.size()));
  for (const scene::ModelCamera& c : scene.cameras) {
    w.putName(c.name);
    w.put(uint32_t(c.perspective ? 1 : 0));
    w.put(c.yfov), w.put(c.aspectRatio), w.put(c.znear), w.put(c.zfar);
    w.put(c.position), w.put(c.direction), w.put(c.up);
  }
  for (const scene::Image& image : scene.images) {
    w.putName(image.name);
    w.put(image.width), w.put(image.height);
    w.put(uint32_t(image.rgba.size()));
    w.bytes().append(reinterpret_cast<const char*>(image.rgba.data()), image.rgba.size());
  }
  encodeAnimation(scene, w);
  const uint64_t body = w.bytes().size() - kHeaderBytes;
  std::memcpy(w.bytes().data() + kHeaderBytes - 8, &body, 8);
  return std::move(w.bytes());
}

scene::Scene decodeScene(std::string_view bytes) {
  if (bytes.size() < kHeaderBytes) reject("shorter than the header");
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) reject("not a scene (bad magic)");
  Reader r(bytes.substr(4));
  if (const uint32_t version = r.get<uint32_t>(); version != kSceneWireVersion) {
    reject("version " + std::to_string(version) + ", expected " +
           std::to_string(kSceneWireVersion));
  }
  const uint32_t meshCount = r.get<uint32_t>();
  const uint32_t materialCount = r.get<uint32_t>();
  const uint32_t instanceCount = r.get<uint32_t>();
  const uint32_t lightCount = r.get<uint32_t>();
  const uint32_t imageCount = r.get<uint32_t>();
  if (r.get<uint64_t>() != r.remaining()) reject("the body size does not match the bytes");
  if (imageCount > scene::ImageLimits{}.maxImages) reject("more images than the limit");
  r.count(meshCount, kMinMeshBytes, "meshes");
  r.count(materialCount, kMinMaterialBytes, "materials");
  r.count(instanceCount, kInstanceBytes, "instances");
  r.count(lightCount, kLightBytes, "lights");
  r.count(imageCount, kMinImageBytes, "images");

  scene::Scene scene;
  scene.sun.direction = r.vec3("the sun");
  scene.sun.color = r.vec3("the sun");
  scene.sun.intensity = r.inRange("the sun's intensity", 0.0f, 1e4f);
  if (glm::length(scene.sun.direction) < 1e-6f) reject("a zero sun direction");
  scene.ambient = r.vec3("the ambient colour");
  scene.background = r.vec3("the background colour");
  scene::Camera& camera = scene.camera;
  camera.eye = r.vec3("the camera");
  camera.target = r.vec3("the camera");
  camera.up = r.vec3("the camera");
  camera.fovYDegrees = r.inRange("the camera's field of view", 1.0f, 179.0f);
  camera.nearPlane = r.finite("the camera");
  camera.farPlane = r.finite("the camera");
  if (!(camera.nearPlane > 0.0f && camera.farPlane > camera.nearPlane)) {
    reject("camera planes out of order");
  }

  scene.materials.reserve(materialCount);
  for (uint32_t i = 0; i < materialCount; ++i) {
    scene::Material m;
    m.name = r.name();
    m.baseColor = r.unitVec3("a base colour");
    m.metallic = r.inRange("a metallic factor", 0.0f, 1.0f);
    m.roughness = r.inRange("a roughness factor", 0.0f, 1.0f);
    m.alpha = r.inRange("a base colour alpha", 0.0f, 1.0f);
    m.emissive = r.unitVec3("an emissive factor");
    m.emissiveStrength = r.inRange("an emissive strength", 0.0f, 1e4f);
    m.normalScale = r.inRange("a normal scale", -100.0f, 100.0f);
    m.occlusionStrength = r.inRange("an occlusion strength", 0.0f, 1.0f);
    m.alphaMode = scene::AlphaMode(r.small("an alpha mode", 3));
    m.alphaCutoff = r.inRange("an alpha cutoff", 0.0f, 1.0f);
    m.doubleSided = r.small("a double-sided flag", 2) != 0;
    m.unlit = r.small("an unlit flag", 2) != 0;
    m.ior = r.inRange("an index of refraction", 1.0f, 10.0f);
    m.specular = r.inRange("a specular factor", 0.0f, 1.0f);
    m.clearcoat = r.inRange("a clearcoat factor", 0.0f, 1.0f);
    m.clearcoatRoughness = r.inRange("a clearcoat roughness", 0.0f, 1.0f);
    m.sheenColor = r.unitVec3("a sheen colour");
    m.sheenRoughness = r.inRange("a sheen roughness", 0.0f, 1.0f);
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
      scene::TextureRef& t = m.texture(slot);
      t.image = r.get<uint32_t>();
      if (t.image != scene::TextureRef::kNone && t.image >= imageCount) {
        reject("a texture of an image that does not exist");
      }
      t.sampler.wrapS = scene::Sampler::Wrap(r.small("a wrap mode", 3));
      t.sampler.wrapT = scene::Sampler::Wrap(r.small("a wrap mode", 3));
      t.sampler.magFilter = scene::Sampler::Filter(r.small("a filter", 2));
      t.sampler.minFilter = scene::Sampler::Filter(r.small("a filter", 2));
      t.sampler.mipmaps = r.small("a mipmap flag", 2) != 0;
      t.sampler.mipmapFilter = scene::Sampler::Filter(r.small("a filter", 2));
      t.offset = r.vec2("a texture transform");
      t.scale = r.vec2("a texture transform");
      t.rotation = r.finite("a texture transform");
      if (glm::any(glm::greaterThan(glm::abs(t.offset), glm::vec2(1e6f))) ||
          glm::any(glm::greaterThan(glm::abs(t.scale), glm::vec2(1e6f))) ||
          std::abs(t.rotation) > 1e6f) {
        reject("a texture transform out of range");
      }
      t.texCoord = r.get<uint32_t>();
      if (t.texCoord != 0) reject("a texture coordinate set other than 0");
    }
    scene.materials.push_back(std::move(m));
  }

  scene.meshes.reserve(meshCount);
  for (uint32_t i = 0; i < meshCount; ++i) {
    scene::Mesh mesh;
    mesh.name = r.name();
    const uint32_t vertexCount = r.count(r.get<uint32_t>(), kVertexBytes, "vertices");
    const uint32_t indexCount = r.get<uint32_t>();
    if (uint64_t(vertexCount) * kVertexBytes + uint64_t(indexCount) * 4 > r.remaining()) {
      reject("more vertices and indices than the bytes can hold");
    }
    if (vertexCount == 0 || indexCount == 0 || indexCount % 3 != 0) {
      reject("a mesh that is not a non-empty triangle list");
    }
    mesh.vertices.resize(vertexCount);
    for (scene::Vertex& v : mesh.vertices) {
      v.position = r.vec3("a vertex position");
      v.normal = r.vec3("a vertex normal");
      v.uv = r.vec2("a texture coordinate");
      v.tangent = r.vec4("a vertex tangent");
      // A tangent is a unit vector with a sign of -1 or 1, or all zero (none in the file).
      const float tangentLength = glm::length(glm::vec3(v.tangent));
      if (v.tangent.w == 0.0f ? tangentLength != 0.0f
                              : (std::abs(v.tangent.w) != 1.0f || std::abs(tangentLength - 1.0f) > 1e-3f)) {
        reject("a vertex tangent that is neither a unit vector with a sign of -1 or 1 nor zero");
      }
      v.color = r.vec4("a vertex colour");
      if (glm::any(glm::lessThan(v.color, glm::vec4(0.0f))) ||
          glm::any(glm::greaterThan(v.color, glm::vec4(1.0f)))) {
        reject("a vertex colour out of range");
      }
    }
    mesh.indices.resize(indexCount);
    for (uint32_t& index : mesh.indices) {
      index = r.get<uint32_t>();
      if (index >= vertexCount) reject("a vertex index out of range");
    }
    scene.meshes.push_back(std::move(mesh));
  }

  scene.instances.reserve(instanceCount);
  for (uint32_t i = 0; i < instanceCount; ++i) {
    scene::Instance instance;
    instance.mesh = r.get<uint32_t>();
    instance.material = r.get<uint32_t>();
    if (instance.mesh >= meshCount) reject("an instance of a mesh that does not exist");
    if (instance.material >= materialCount) reject("an instance of a material that does not exist");
    instance.transform = r.mat4("a transform");
    scene.instances.push_back(instance);
  }

  scene.lights.reserve(lightCount);
  for (uint32_t i = 0; i < lightCount; ++i) {
    scene::PointLight light;
    light.position = r.vec3("a light position");
    light.radius = r.inRange("a light radius", 0.0f, 3.0e38f);
    light.color = r.vec3("a light colour");
    light.intensity = r.inRange("a light intensity", 0.0f, 3.0e38f);
    light.falloff = r.inRange("a light falloff", 0.0f, 3.0e38f);
    if (!(light.radius > 0.0f)) reject("a light radius of zero");
    const uint32_t type = r.get<uint32_t>();
    const uint32_t attenuation = r.get<uint32_t>();
    if (type > uint32_t(scene::LightType::Spot)) reject("an unknown light type");
    if (attenuation > uint32_t(scene::Attenuation::InverseSquare)) reject("an unknown light attenuation");
    light.type = scene::LightType(type);
    light.attenuation = scene::Attenuation(attenuation);
    light.direction = r.vec3("a light direction");
    if (std::abs(glm::length(light.direction) - 1.0f) > 1e-3f) reject("a light direction that is not a unit vector");
    light.innerConeAngle = r.inRange("a spot's inner cone angle", 0.0f, scene::kMaxConeAngle);
    light.outerConeAngle = r.inRange("a spot's outer cone angle", 0.0f, scene::kMaxConeAngle);
    if (!(light.innerConeAngle < light.outerConeAngle)) reject("a spot cone with inner >= outer");
    scene.lights.push_back(light);
  }
  const uint32_t sunCount = r.get<uint32_t>();
  if (sunCount > scene::kMaxExtraSuns) reject("more directional lights than the sun's companions");
  for (uint32_t i = 0; i < sunCount; ++i) {
    scene::Sun sun;
    sun.direction = r.vec3("a directional light");
    if (std::abs(glm::length(sun.direction) - 1.0f) > 1e-3f) reject("a directional light's direction that is not a unit vector");
    sun.color = r.unitVec3("a directional light's colour");
    sun.intensity = r.inRange("a directional light's intensity", 0.0f, 1000.0f);
    scene.extraSuns.push_back(sun);
  }
  scene.droppedSuns = r.get<uint32_t>();
  const uint32_t ignoredCount = r.count(r.get<uint32_t>(), 4, "ignored extensions");
  if (ignoredCount > kMaxWireIgnoredExtensions) reject("more ignored extensions than the limit");
  for (uint32_t i = 0; i < ignoredCount; ++i) scene.ignoredExtensions.push_back(r.name());
  const uint32_t cameraCount = r.count(r.get<uint32_t>(), kMinCameraBytes, "cameras");
  if (cameraCount > kMaxWireCameras) reject("more than " + std::to_string(kMaxWireCameras) + " cameras");
  scene.cameras.reserve(cameraCount);
  for (uint32_t i = 0; i < cameraCount; ++i) {
    scene::ModelCamera c;
    c.name = r.name();
    const uint32_t perspective = r.get<uint32_t>();
    if (perspective > 1) reject("an unknown camera type");
    c.perspective = perspective == 1;
    c.yfov = r.inRange("a camera's field of view", 0.0f, 3.2f);
    c.aspectRatio = r.inRange("a camera's aspect ratio", 0.0f, 1e6f);
    c.znear = r.inRange("a camera's near plane", 0.0f, 3.0e38f);
    c.zfar = r.inRange("a camera's far plane", 0.0f, 3.0e38f);
    if (c.perspective && !(c.yfov > 0.0f && c.znear > 0.0f)) reject("a perspective camera without a field of view or near plane");
    if (c.zfar != 0.0f && !(c.zfar > c.znear)) reject("a camera's planes out of order");
    c.position = r.vec3("a camera position");
    c.direction = r.vec3("a camera direction");
    c.up = r.vec3("a camera's up");
    if (std::abs(glm::length(c.direction) - 1.0f) > 1e-3f || std::abs(glm::length(c.up) - 1.0f) > 1e-3f ||
        std::abs(glm::dot(c.direction, c.up)) > 1e-2f) {
      reject("a camera whose direction and up are not perpendicular unit vectors");
    }
    scene.cameras.push_back(std::move(c));
  }

  const scene::ImageLimits imageLimits;
  uint64_t imageBytes = 0;
  scene.images.reserve(imageCount);
  for (uint32_t i = 0; i < imageCount; ++i) {
    scene::Image image;
    image.name = r.name();
    image.width = r.get<uint32_t>();
    image.height = r.get<uint32_t>();
    const uint32_t size = r.get<uint32_t>();
    if (image.width == 0 || image.height == 0 || image.width > imageLimits.maxDimension ||
        image.height > imageLimits.maxDimension) {
      reject("an image size out of range");
    }
    if (uint64_t(size) != uint64_t(image.width) * image.height * 4) {
      reject("an image whose bytes do not match its size");
    }
    imageBytes += size;
    if (imageBytes > imageLimits.maxDecodedBytes) reject("more image bytes than the limit");
    const std::string_view pixels = r.take(size);
    image.rgba.assign(pixels.begin(), pixels.end());
    scene.images.push_back(std::move(image));
  }
  decodeAnimation(r, scene);
  if (r.remaining() != 0) reject("bytes after the end of the scene");
  return scene;
}

}  // namespace myriad::loader
