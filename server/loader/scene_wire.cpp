#include "loader/scene_wire.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <type_traits>

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

 private:
  void need(size_t n) {
    if (n > remaining()) reject("truncated");
  }

  std::string_view bytes_;
  size_t at_ = 0;
};

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
    w.put(uint8_t(m.doubleSided));
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
    m.baseColor = r.vec3("a base colour");
    if (glm::any(glm::lessThan(m.baseColor, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(m.baseColor, glm::vec3(1.0f)))) {
      reject("a base colour out of range");
    }
    m.metallic = r.inRange("a metallic factor", 0.0f, 1.0f);
    m.roughness = r.inRange("a roughness factor", 0.0f, 1.0f);
    m.alpha = r.inRange("a base colour alpha", 0.0f, 1.0f);
    m.emissive = r.vec3("an emissive factor");
    if (glm::any(glm::lessThan(m.emissive, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(m.emissive, glm::vec3(1.0f)))) {
      reject("an emissive factor out of range");
    }
    m.emissiveStrength = r.inRange("an emissive strength", 0.0f, 1e4f);
    m.normalScale = r.inRange("a normal scale", -100.0f, 100.0f);
    m.occlusionStrength = r.inRange("an occlusion strength", 0.0f, 1.0f);
    m.alphaMode = scene::AlphaMode(r.small("an alpha mode", 3));
    m.alphaCutoff = r.inRange("an alpha cutoff", 0.0f, 1.0f);
    m.doubleSided = r.small("a double-sided flag", 2) != 0;
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
    sun.color = r.vec3("a directional light's colour");
    if (glm::any(glm::lessThan(sun.color, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(sun.color, glm::vec3(1.0f)))) {
      reject("a directional light's colour out of range");
    }
    sun.intensity = r.inRange("a directional light's intensity", 0.0f, 1000.0f);
    scene.extraSuns.push_back(sun);
  }
  scene.droppedSuns = r.get<uint32_t>();
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
  if (r.remaining() != 0) reject("bytes after the end of the scene");
  return scene;
}

}  // namespace myriad::loader
