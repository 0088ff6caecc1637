#include "scene/model_loader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <unordered_map>
#include <vector>

#include <assimp/DefaultIOSystem.h>
#include <assimp/GltfMaterial.h>
#include <assimp/MemoryIOWrapper.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "scene/animation.h"
#include "scene/camera.h"
#include "scene/gltf_animation.h"
#include "scene/gltf_materials.h"
#include "scene/image_decode.h"
#include "scene/memory_files.h"
#include "scene/model_animation.h"
#include "scene/tangents.h"

namespace myriad::scene {

namespace {

// A real model is a few levels deep; anything deeper is a cycle Assimp did not catch or a file
// built to exhaust the stack.
constexpr int kMaxNodeDepth = 64;
// Bounds on flattening: a DAG of nodes that share children multiplies out exponentially, so both
// the nodes visited and the instances produced are capped, and the file rejected past either.
constexpr size_t kMaxNodeVisits = size_t(1) << 20;
constexpr size_t kMaxInstances = size_t(1) << 18;

// Where a light without a glTF `range` is cut: its inverse-square illuminance has fallen to 1/256
// of what it is at unit distance, about one step of an 8-bit image at unit exposure.
constexpr float kLightCutoff = 1.0f / 256.0f;
// What the protocol accepts for a light (light.schema.json): what a file exceeds is clamped.
constexpr float kMaxLightIntensity = 1e6f;
constexpr float kMaxLightRadius = 1e4f;
constexpr float kMaxLightFalloff = 1e4f;
constexpr float kMaxSunIntensity = 1000.0f;  // settings.schema.json's sun intensity

// Everything reaching the renderer comes from here, so each step is chosen for what it guarantees
// on a broken file as much as for what it does on a good one:
// - Triangulate: the renderer draws triangle lists only.
// - SortByPType (with SBP_REMOVE): splits mixed meshes so that points and lines go whole.
// - FindDegenerates (with FD_REMOVE): zero-area triangles are removed, not turned into lines.
// - FindInvalidData: deletes meshes with NaN/inf positions. It runs before the spatial sorts of the
//   two steps below, whose comparisons assume finite keys.
// - GenSmoothNormals: only where the file has none.
// - JoinIdenticalVertices: indexed meshes; OBJ and others arrive unwelded. Not for models with
//   skins or morph targets (convertImport says why).
// - FlipUVs: uv origin at the top left, as Vulkan addresses images (and as glTF stores them).
constexpr unsigned kPostProcess = aiProcess_Triangulate | aiProcess_SortByPType |
                                  aiProcess_FindDegenerates | aiProcess_FindInvalidData |
                                  aiProcess_GenSmoothNormals | aiProcess_JoinIdenticalVertices |
                                  aiProcess_FlipUVs;

using Kind = ModelLoadError::Kind;

[[noreturn]] void fail(const std::string& name, const std::string& reason,
                       Kind kind = Kind::parse) {
  throw ModelLoadError("Cannot load model '" + name + "': " + reason, kind);
}

// The file system as Assimp sees it while importing: only files at or below `root` exist, and with
// an empty root (an upload, read from memory) none do. Without this, a glTF buffer URI such as
// "../../etc/shadow" or an absolute path would be read and turned into geometry. Records what was
// refused so that the error can say so.
class ConfinedIOSystem : public Assimp::DefaultIOSystem {
 public:
  explicit ConfinedIOSystem(std::filesystem::path root) : root_(std::move(root)) {}

  bool Exists(const char* file) const override {
    return allowed(file) && Assimp::DefaultIOSystem::Exists(file);
  }

  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (!allowed(file) || std::string_view(mode).find_first_of("wa+") != std::string_view::npos) {
      if (refused_.size() < 4) refused_.emplace_back(file);
      return nullptr;
    }
    return Assimp::DefaultIOSystem::Open(file, mode);
  }

  const std::vector<std::string>& refused() const { return refused_; }

 private:
  bool allowed(const char* file) const {
    if (root_.empty() || file == nullptr) return false;
    std::error_code error;
    const std::filesystem::path resolved = std::filesystem::weakly_canonical(file, error);
    if (error) return false;
    const std::filesystem::path relative = resolved.lexically_relative(root_);
    return !relative.empty() && *relative.begin() != ".." && relative.is_relative();
  }

  std::filesystem::path root_;
  mutable std::vector<std::string> refused_;
};

// The file system as Assimp sees it while importing an upload of several files: the members of
// the set and nothing else (no absolute path, nothing above the set's root, no real file). Paths
// are taken relative to the set's root, as Assimp builds them from the model's own path.
class MemberIOSystem : public Assimp::IOSystem {
 public:
  explicit MemberIOSystem(const MemoryFiles& files) : files_(files) {}

  bool Exists(const char* file) const override {
    return file != nullptr && findMember(files_, file) != nullptr;
  }
  char getOsSeparator() const override { return '/'; }

  Assimp::IOStream* Open(const char* file, const char* mode) override {
    const std::string* bytes = file != nullptr ? findMember(files_, file) : nullptr;
    if (bytes == nullptr || std::string_view(mode).find_first_of("wa+") != std::string_view::npos) {
      if (refused_.size() < 4 && file != nullptr) refused_.emplace_back(file);
      return nullptr;
    }
    return new Assimp::MemoryIOStream(reinterpret_cast<const uint8_t*>(bytes->data()),
                                      bytes->size());
  }
  void Close(Assimp::IOStream* stream) override { delete stream; }

  const std::vector<std::string>& refused() const { return refused_; }

 private:
  const MemoryFiles& files_;
  std::vector<std::string> refused_;
};

void configure(Assimp::Importer& importer) {
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  importer.SetPropertyBool(AI_CONFIG_PP_FD_REMOVE, true);
  // Without this, a file holding only a skeleton (BVH, some FBX) "loads" as a bone-shaped mesh.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);
}

std::string lowerExtension(std::string_view extension) {
  if (!extension.empty() && extension.front() == '.') extension.remove_prefix(1);
  std::string lower(extension);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return lower;
}

bool isFinite(const aiVector3D& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool isFinite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

float clampOr(float value, float low, float high, float fallback) {
  return std::isfinite(value) ? std::clamp(value, low, high) : fallback;
}

glm::mat4 toGlm(const aiMatrix4x4& m) {
  // Assimp stores rows (a1..a4 is the first row); glm stores columns.
  return glm::mat4(m.a1, m.b1, m.c1, m.d1, m.a2, m.b2, m.c2, m.d2, m.a3, m.b3, m.c3, m.d3, m.a4,
                   m.b4, m.c4, m.d4);
}

Material convertMaterial(const aiMaterial& source, size_t index) {
  Material material;
  aiString name;
  material.name = source.Get(AI_MATKEY_NAME, name) == AI_SUCCESS && name.length > 0
                      ? std::string(name.C_Str())
                      : "material " + std::to_string(index);

  aiColor4D color;
  if (source.Get(AI_MATKEY_BASE_COLOR, color) == AI_SUCCESS ||
      source.Get(AI_MATKEY_COLOR_DIFFUSE, color) == AI_SUCCESS) {
    const glm::vec3 fallback = Material{}.baseColor;
    material.baseColor = {clampOr(color.r, 0.0f, 1.0f, fallback.r),
                          clampOr(color.g, 0.0f, 1.0f, fallback.g),
                          clampOr(color.b, 0.0f, 1.0f, fallback.b)};
  }

  float value = 0.0f;
  if (source.Get(AI_MATKEY_METALLIC_FACTOR, value) == AI_SUCCESS) {
    material.metallic = clampOr(value, 0.0f, 1.0f, Material{}.metallic);
  }
  if (source.Get(AI_MATKEY_ROUGHNESS_FACTOR, value) == AI_SUCCESS) {
    material.roughness = clampOr(value, 0.0f, 1.0f, Material{}.roughness);
  } else if (source.Get(AI_MATKEY_GLOSSINESS_FACTOR, value) == AI_SUCCESS) {
    material.roughness = clampOr(1.0f - value, 0.0f, 1.0f, Material{}.roughness);
  } else if (source.Get(AI_MATKEY_SHININESS, value) == AI_SUCCESS && std::isfinite(value)) {
    // Blinn-Phong exponent n to GGX: alpha = sqrt(2 / (n + 2)) matches the lobes' widths (Walter et
    // al. 2007), and roughness = sqrt(alpha) since the BRDF squares roughness into alpha.
    const float alpha = std::sqrt(2.0f / (std::max(value, 0.0f) + 2.0f));
    material.roughness = clampOr(std::sqrt(alpha), 0.0f, 1.0f, Material{}.roughness);
  }
  return material;
}

// Reads the images a model's materials use, once each, through the importer's IOSystem (so an
// upload reads only its own members, a library model only its own directory), and decodes them
// under ImageLimits. glTF says exactly which images it needs, so there a missing or unreadable
// one refuses the model; the older formats often name files from their author's disk, so there a
// missing texture leaves the material untextured. A corrupt image, or one over a limit, refuses
// the model in every format.
class ImageCollector {
 public:
  ImageCollector(const aiScene& source, Assimp::IOSystem* io, std::string directory, bool strict,
                 const std::string& name, Scene& scene)
      : source_(source), io_(io), directory_(std::move(directory)), strict_(strict), name_(name),
        scene_(scene) {}

  // The scene image for the material texture `path`, or TextureRef::kNone.
  uint32_t imageFor(const aiString& path) {
    const std::string key(path.C_Str());
    if (key.empty()) return TextureRef::kNone;
    if (auto it = byPath_.find(key); it != byPath_.end()) return it->second;
    const uint32_t index = load(key);
    byPath_.emplace(key, index);
    return index;
  }

 private:
  uint32_t add(Image image) {
    if (scene_.images.size() >= limits_.maxImages) {
      fail(name_,
           "it uses more than " + std::to_string(limits_.maxImages) +
               " images (the image count limit)",
           Kind::tooLarge);
    }
    used_ += image.rgba.size();
    scene_.images.push_back(std::move(image));
    return uint32_t(scene_.images.size() - 1);
  }

  uint32_t decode(std::string_view bytes, const std::string& label) {
    // Counted before decoding, so a model of a thousand tiny images is refused at the limit.
    if (scene_.images.size() >= limits_.maxImages) {
      fail(name_,
           "it uses more than " + std::to_string(limits_.maxImages) +
               " images (the image count limit)",
           Kind::tooLarge);
    }
    Image image;
    try {
      image = decodeImage(bytes, label, limits_, limits_.maxDecodedBytes - used_);
    } catch (const ModelLoadError& e) {
      // Over a limit: refused in every format. A corrupt image, or one in a format this server
      // does not decode (TGA, BMP, DDS are common in OBJ and FBX files): refused in glTF, whose
      // images are PNG or JPEG by the spec; elsewhere the material stays untextured.
      if (e.kind() != Kind::tooLarge && !strict_) return TextureRef::kNone;
      fail(name_, e.what(), e.kind());
    }
    image.name = label;
    return add(std::move(image));
  }

  uint32_t load(const std::string& key) {
    // Embedded: "*N" (glTF buffer views and data URIs, GLB) or a file name FBX embeds.
    if (const aiTexture* texture = source_.GetEmbeddedTexture(key.c_str())) {
      const std::string label =
          texture->mFilename.length > 0 ? std::string(texture->mFilename.C_Str()) : key;
      if (texture->pcData == nullptr) fail(name_, "the embedded image '" + label + "' is empty");
      if (texture->mHeight == 0) {
        return decode(std::string_view(reinterpret_cast<const char*>(texture->pcData),
                                       texture->mWidth),
                      label);
      }
      return addTexels(*texture, label);
    }
    if (key.front() == '*') {
      fail(name_, "it refers to the embedded image '" + key + "', which it does not hold");
    }
    if (io_ == nullptr) return missing(key);
    // As written, percent-decoded (glTF URIs), and with '\\' as '/' (models made on Windows:
    // "map_Kd .\\wood.jpg").
    std::string slashed = key;
    std::replace(slashed.begin(), slashed.end(), '\\', '/');
    for (const std::string& candidate : {key, percentDecoded(key), slashed}) {
      const std::string path = directory_.empty() ? candidate : directory_ + "/" + candidate;
      if (!io_->Exists(path.c_str())) continue;
      std::unique_ptr<Assimp::IOStream, std::function<void(Assimp::IOStream*)>> stream(
          io_->Open(path.c_str(), "rb"), [this](Assimp::IOStream* s) { io_->Close(s); });
      if (!stream) continue;
      const size_t size = stream->FileSize();
      // A compressed image larger than the decoded budget cannot be a valid one within it.
      if (size > limits_.maxDecodedBytes) {
        fail(name_, "the image '" + candidate + "' is larger than the " +
                        std::to_string(limits_.maxDecodedBytes >> 20) +
                        " MiB limit of decoded image bytes per model",
             Kind::tooLarge);
      }
      std::string bytes(size, '\0');
      if (size > 0 && stream->Read(bytes.data(), 1, size) != size) {
        fail(name_, "the image '" + candidate + "' could not be read");
      }
      return decode(bytes, candidate);
    }
    return missing(key);
  }

  uint32_t missing(const std::string& key) {
    if (strict_ && io_ == nullptr) {
      fail(name_,
           "it refers to the separate image '" + key +
               "', which an upload of one file cannot carry (send a .glb, a .zip of the model "
               "and its files, or several files)",
           Kind::unsupported);
    }
    if (strict_) fail(name_, "it refers to the image '" + key + "', which is missing");
    return TextureRef::kNone;
  }

  // Uncompressed embedded texels (aiTexel is B, G, R, A).
  uint32_t addTexels(const aiTexture& texture, const std::string& label) {
    if (texture.mWidth > limits_.maxDimension || texture.mHeight > limits_.maxDimension) {
      fail(name_, "the image '" + label + "' is over the texture dimension limit of " +
                      std::to_string(limits_.maxDimension), Kind::tooLarge);
    }
    Image image;
    image.name = label;
    image.width = texture.mWidth;
    image.height = texture.mHeight;
    const size_t count = size_t(image.width) * image.height;
    if (count * 4 > limits_.maxDecodedBytes - used_) {
      fail(name_, "its images decode to more than the limit of " +
                      std::to_string(limits_.maxDecodedBytes >> 20) +
                      " MiB of decoded image bytes per model", Kind::tooLarge);
    }
    image.rgba.resize(count * 4);
    for (size_t i = 0; i < count; ++i) {
      const aiTexel& t = texture.pcData[i];
      image.rgba[4 * i + 0] = t.r;
      image.rgba[4 * i + 1] = t.g;
      image.rgba[4 * i + 2] = t.b;
      image.rgba[4 * i + 3] = t.a;
    }
    return add(std::move(image));
  }

  static std::string percentDecoded(const std::string& uri) {
    std::string out;
    for (size_t i = 0; i < uri.size(); ++i) {
      if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit((unsigned char)uri[i + 1]) &&
          std::isxdigit((unsigned char)uri[i + 2])) {
        out += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
        i += 2;
      } else {
        out += uri[i];
      }
    }
    return out;
  }

  const aiScene& source_;
  Assimp::IOSystem* io_;
  std::string directory_;
  bool strict_;
  const std::string& name_;
  Scene& scene_;
  ImageLimits limits_;
  uint64_t used_ = 0;
  std::map<std::string, uint32_t> byPath_;
};

Sampler::Wrap wrapOf(int mode) {
  return mode == aiTextureMapMode_Clamp    ? Sampler::Wrap::clampToEdge
         : mode == aiTextureMapMode_Mirror ? Sampler::Wrap::mirroredRepeat
                                           : Sampler::Wrap::repeat;
}

// KHR_texture_transform back from Assimp's aiUVTransform. Assimp 5.2.5's glTF importer turns
// (offset o, rotation r, scale s) into a transform about its bottom-left uv origin:
//   scaling = s, rotation = -r,
//   translation.x = 0.5 s.x (-cos r + sin r + 1) + o.x,
//   translation.y = 0.5 s.y (sin r + cos r - 1) + 1 - s.y - o.y,
// and FlipUVs (back to glTF's top-left origin) negates translation.y and rotation. Inverting both
// gives the file's values (glTF2/textureTransform/TextureTransformTest.gltf checks this).
void readTextureTransform(const aiMaterial& source, aiTextureType type, TextureRef& ref) {
  aiUVTransform t;
  if (source.Get(AI_MATKEY_UVTRANSFORM(type, 0), t) != AI_SUCCESS) return;
  const float r = t.mRotation;
  const float c = std::cos(r), s = std::sin(r);
  const glm::vec2 scale(t.mScaling.x, t.mScaling.y);
  const glm::vec2 offset(t.mTranslation.x - 0.5f * scale.x * (-c + s + 1.0f),
                         t.mTranslation.y + 0.5f * scale.y * (s + c - 1.0f) + 1.0f - scale.y);
  if (!std::isfinite(r + scale.x + scale.y + offset.x + offset.y)) return;
  ref.rotation = std::clamp(r, -1e6f, 1e6f);
  ref.scale = glm::clamp(scale, glm::vec2(-1e6f), glm::vec2(1e6f));
  ref.offset = glm::clamp(offset, glm::vec2(-1e6f), glm::vec2(1e6f));
}

// The texture of `type` (index 0) of `source`, with its sampler, into `ref`.
bool readTexture(const aiMaterial& source, aiTextureType type, ImageCollector& images,
                 TextureRef& ref) {
  aiString path;
  if (source.GetTextureCount(type) == 0 || source.GetTexture(type, 0, &path) != AI_SUCCESS) {
    return false;
  }
  const uint32_t image = images.imageFor(path);
  if (image == TextureRef::kNone) return false;
  ref = TextureRef{};
  ref.image = image;
  readTextureTransform(source, type, ref);
  int mode = 0;
  if (source.Get(AI_MATKEY_MAPPINGMODE_U(type, 0), mode) == AI_SUCCESS) ref.sampler.wrapS = wrapOf(mode);
  if (source.Get(AI_MATKEY_MAPPINGMODE_V(type, 0), mode) == AI_SUCCESS) ref.sampler.wrapT = wrapOf(mode);
  // glTF's sampler filters (GL enums); absent means "the renderer's choice": linear, mipmapped.
  int filter = 0;
  if (source.Get(AI_MATKEY_GLTF_MAPPINGFILTER_MAG(type, 0), filter) == AI_SUCCESS) {
    ref.sampler.magFilter = filter == 9728 ? Sampler::Filter::nearest : Sampler::Filter::linear;
  }
  if (source.Get(AI_MATKEY_GLTF_MAPPINGFILTER_MIN(type, 0), filter) == AI_SUCCESS) {
    // 9728 NEAREST, 9729 LINEAR, 9984 NEAREST_MIPMAP_NEAREST, 9985 LINEAR_MIPMAP_NEAREST,
    // 9986 NEAREST_MIPMAP_LINEAR, 9987 LINEAR_MIPMAP_LINEAR
    const bool nearest = filter == 9728 || filter == 9984 || filter == 9986;
    ref.sampler.minFilter = nearest ? Sampler::Filter::nearest : Sampler::Filter::linear;
    ref.sampler.mipmaps = filter >= 9984 && filter <= 9987;
    ref.sampler.mipmapFilter =
        filter == 9984 || filter == 9985 ? Sampler::Filter::nearest : Sampler::Filter::linear;
  }
  return true;
}


// The glTF material beyond the factors convertMaterial reads, and the textures of every format.
void readMaterialExtras(const aiMaterial& source, bool gltf, ImageCollector& images,
                        Material& material) {
  if (!readTexture(source, aiTextureType_BASE_COLOR, images, material.baseColorTexture)) {
    readTexture(source, aiTextureType_DIFFUSE, images, material.baseColorTexture);
  }
  if (!gltf) return;  // the other formats' maps mean other things (bump, specular, ...)

  aiColor4D color;
  if (source.Get(AI_MATKEY_BASE_COLOR, color) == AI_SUCCESS) {
    material.alpha = clampOr(color.a, 0.0f, 1.0f, 1.0f);
  }
  aiColor3D emissive;
  if (source.Get(AI_MATKEY_COLOR_EMISSIVE, emissive) == AI_SUCCESS) {
    material.emissive = {clampOr(emissive.r, 0.0f, 1.0f, 0.0f), clampOr(emissive.g, 0.0f, 1.0f, 0.0f),
                         clampOr(emissive.b, 0.0f, 1.0f, 0.0f)};
  }
  float value = 0.0f;
  if (source.Get(AI_MATKEY_EMISSIVE_INTENSITY, value) == AI_SUCCESS) {
    material.emissiveStrength = clampOr(value, 0.0f, 1e4f, 1.0f);
  }
  aiString alphaMode;
  if (source.Get(AI_MATKEY_GLTF_ALPHAMODE, alphaMode) == AI_SUCCESS) {
    const std::string mode = alphaMode.C_Str();
    material.alphaMode = mode == "MASK"    ? AlphaMode::mask
                         : mode == "BLEND" ? AlphaMode::blend
                                           : AlphaMode::opaque;
  }
  if (source.Get(AI_MATKEY_GLTF_ALPHACUTOFF, value) == AI_SUCCESS) {
    material.alphaCutoff = clampOr(value, 0.0f, 1.0f, 0.5f);
  }
  int twoSided = 0;
  material.doubleSided = source.Get(AI_MATKEY_TWOSIDED, twoSided) == AI_SUCCESS && twoSided != 0;

  if (!readTexture(source, aiTextureType_UNKNOWN, images, material.metallicRoughnessTexture)) {
    readTexture(source, aiTextureType_METALNESS, images, material.metallicRoughnessTexture);
  }
  if (readTexture(source, aiTextureType_NORMALS, images, material.normalTexture) &&
      source.Get(AI_MATKEY_GLTF_TEXTURE_SCALE(aiTextureType_NORMALS, 0), value) == AI_SUCCESS) {
    material.normalScale = clampOr(value, -100.0f, 100.0f, 1.0f);
  }
  if ((readTexture(source, aiTextureType_LIGHTMAP, images, material.occlusionTexture) &&
       source.Get(AI_MATKEY_GLTF_TEXTURE_STRENGTH(aiTextureType_LIGHTMAP, 0), value) ==
           AI_SUCCESS) ||
      (readTexture(source, aiTextureType_AMBIENT_OCCLUSION, images, material.occlusionTexture) &&
       source.Get(AI_MATKEY_GLTF_TEXTURE_STRENGTH(aiTextureType_AMBIENT_OCCLUSION, 0), value) ==
           AI_SUCCESS)) {
    material.occlusionStrength = clampOr(value, 0.0f, 1.0f, 1.0f);
  }
  readTexture(source, aiTextureType_EMISSIVE, images, material.emissiveTexture);
}

bool isGltf(const std::string& name);

// Copies the triangles of `source` whose corners are all finite and in range, keeping only the
// vertices they use: an unreferenced NaN vertex would otherwise still poison the bounds.
// `sourceOf` receives, per kept vertex, the source vertex it came from (for skins and morphs).
// `normalMapUv`: its material has a normal map, sampled through this uv transform (linear part),
// so tangents are made where the file has none.
Mesh convertMesh(const aiMesh& source, size_t index, detail::SourceVertices& sourceOf,
                 const std::optional<glm::mat2>& normalMapUv) {
  Mesh mesh;
  mesh.name =
      source.mName.length > 0 ? std::string(source.mName.C_Str()) : "mesh " + std::to_string(index);
  if (!(source.mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || source.mVertices == nullptr) {
    return mesh;
  }
  const unsigned vertexCount = source.mNumVertices;
  const aiVector3D* uvs = source.HasTextureCoords(0) ? source.mTextureCoords[0] : nullptr;
  std::vector<uint32_t> remap(vertexCount, UINT32_MAX);
  std::vector<bool> needsNormal;

  for (unsigned f = 0; f < source.mNumFaces; ++f) {
    const aiFace& face = source.mFaces[f];
    if (face.mNumIndices != 3 || face.mIndices == nullptr) continue;
    bool usable = true;
    for (unsigned k = 0; k < 3; ++k) {
      const unsigned i = face.mIndices[k];
      usable = usable && i < vertexCount && isFinite(source.mVertices[i]);
    }
    if (!usable) continue;
    for (unsigned k = 0; k < 3; ++k) {
      const unsigned i = face.mIndices[k];
      if (remap[i] == UINT32_MAX) {
        remap[i] = uint32_t(mesh.vertices.size());
        Vertex vertex;
        const aiVector3D& p = source.mVertices[i];
        vertex.position = {p.x, p.y, p.z};
        bool normalOk = false;
        if (source.mNormals != nullptr && isFinite(source.mNormals[i])) {
          const glm::vec3 n(source.mNormals[i].x, source.mNormals[i].y, source.mNormals[i].z);
          const float length = glm::length(n);
          if (length > 1e-12f && std::isfinite(length)) {
            vertex.normal = n / length;
            normalOk = true;
          }
        }
        if (uvs != nullptr && std::isfinite(uvs[i].x) && std::isfinite(uvs[i].y)) {
          vertex.uv = {uvs[i].x, uvs[i].y};
        }
        // glTF TANGENT arrives as Assimp's tangent and bitangent (w * cross(n, t)): w is recovered
        // from their orientation. Unusable ones are left at w = 0 (derived per pixel instead).
        if (normalOk && source.mTangents != nullptr && source.mBitangents != nullptr &&
            isFinite(source.mTangents[i]) && isFinite(source.mBitangents[i])) {
          const glm::vec3 t(source.mTangents[i].x, source.mTangents[i].y, source.mTangents[i].z);
          const glm::vec3 b(source.mBitangents[i].x, source.mBitangents[i].y,
                            source.mBitangents[i].z);
          const float length = glm::length(t);
          if (length > 1e-12f && std::isfinite(length)) {
            const float w = glm::dot(glm::cross(vertex.normal, t), b) < 0.0f ? -1.0f : 1.0f;
            vertex.tangent = glm::vec4(t / length, w);
          }
        }
        if (source.mColors[0] != nullptr) {
          const aiColor4D& c = source.mColors[0][i];
          if (std::isfinite(c.r + c.g + c.b + c.a)) {
            vertex.color = glm::clamp(glm::vec4(c.r, c.g, c.b, c.a), 0.0f, 1.0f);
          }
        }
        mesh.vertices.push_back(vertex);
        sourceOf.push_back(i);
        needsNormal.push_back(!normalOk);
      }
      mesh.indices.push_back(remap[i]);
    }
  }

  // Files with zero or NaN normals on some vertices (glTF2/BoxBadNormals) get area-weighted face
  // normals there, rather than black or NaN shading.
  if (std::find(needsNormal.begin(), needsNormal.end(), true) != needsNormal.end()) {
    std::vector<glm::vec3> sums(mesh.vertices.size(), glm::vec3(0.0f));
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      const glm::vec3 n = glm::cross(mesh.vertices[b].position - mesh.vertices[a].position,
                                     mesh.vertices[c].position - mesh.vertices[a].position);
      if (!std::isfinite(n.x + n.y + n.z)) continue;
      sums[a] += n;
      sums[b] += n;
      sums[c] += n;
    }
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
      if (!needsNormal[v]) continue;
      const float length = glm::length(sums[v]);
      mesh.vertices[v].normal =
          length > 1e-20f && std::isfinite(length) ? sums[v] / length : glm::vec3(0.0f, 1.0f, 0.0f);
    }
  }
  // glTF asks clients to make MikkTSpace tangents where a file has none, since normal maps are
  // baked against them (scene/tangents.h). Only where a normal map uses them: elsewhere the
  // vertices stay as the file has them. Split vertices keep their source (skins, morphs).
  if (normalMapUv && source.mTangents == nullptr && uvs != nullptr) {
    for (const uint32_t copied : generateTangents(mesh.vertices, mesh.indices, *normalMapUv)) {
      const uint32_t from = sourceOf[copied];
      sourceOf.push_back(from);
    }
  }
  return mesh;
}

// Walks the node tree once, turning every (node, mesh) pair into an Instance and every node that
// carries a light into a PointLight.
class Flattener {
 public:
  Flattener(const aiScene& source, const std::string& name, Scene& scene)
      : source_(source), name_(name), scene_(scene), meshIndex_(source.mNumMeshes, kUnconverted) {
    for (unsigned i = 0; source.mLights != nullptr && i < source.mNumLights; ++i) {
      const aiLight* light = source.mLights[i];
      if (light != nullptr && light->mName.length > 0) {
        lightsByNode_.emplace(std::string(light->mName.C_Str()), light);
      }
    }
    const unsigned cameraCount = source.mCameras != nullptr ? std::min(source.mNumCameras, 65536u) : 0u;
    placedCameras_.resize(cameraCount);
    for (unsigned i = 0; i < cameraCount; ++i) {
      const aiCamera* camera = source.mCameras[i];
      if (camera != nullptr && camera->mName.length > 0) {
        camerasByNode_.emplace(std::string(camera->mName.C_Str()), i);
      }
    }
  }

  // After visit(): the file's directional lights become the scene's extra suns (the brightest
  // kMaxExtraSuns; the rest are counted), and its placed cameras the scene's, in file order.
  void finish() {
    std::stable_sort(suns_.begin(), suns_.end(),
                     [](const Sun& a, const Sun& b) { return a.intensity > b.intensity; });
    const size_t kept = std::min(suns_.size(), kMaxExtraSuns);
    scene_.extraSuns.assign(suns_.begin(), suns_.begin() + kept);
    scene_.droppedSuns = uint32_t(suns_.size() - kept);
    for (std::optional<ModelCamera>& camera : placedCameras_) {
      if (camera) scene_.cameras.push_back(std::move(*camera));
    }
  }

  void visit(const aiNode& node, const glm::mat4& parent, int depth, int32_t parentNode = -1) {
    if (depth > kMaxNodeDepth) {
      fail(name_, "its node hierarchy is deeper than " + std::to_string(kMaxNodeDepth) +
                      " levels (a cycle?)");
    }
    if (++visits_ > kMaxNodeVisits) {
      fail(name_, "it has more than " + std::to_string(kMaxNodeVisits) + " nodes");
    }
    const glm::mat4 transform = parent * toGlm(node.mTransformation);
    // A non-finite transform (a NaN rotation, an overflowing scale) would put NaNs into the bounds
    // and the camera; what hangs below it is skipped instead.
    const bool placeable = isFinite(transform);
    const int32_t nodeIndex = addNode(node, parentNode);
    nodeWorld_.push_back(transform);

    if (placeable && node.mMeshes != nullptr) {
      for (unsigned k = 0; k < node.mNumMeshes; ++k) {
        const unsigned sourceMesh = node.mMeshes[k];
        if (source_.mMeshes == nullptr || sourceMesh >= source_.mNumMeshes ||
            source_.mMeshes[sourceMesh] == nullptr) {
          continue;
        }
        const uint32_t mesh = meshFor(sourceMesh);
        if (mesh == kNoTriangles) continue;
        if (scene_.instances.size() >= kMaxInstances) {
          fail(name_, "it places more than " + std::to_string(kMaxInstances) + " mesh instances");
        }
        Instance instance{mesh, materialFor(source_.mMeshes[sourceMesh]->mMaterialIndex),
                          transform};
        instance.node = nodeIndex;
        // A skinned mesh is placed by its joints (glTF 2.0: the node's own transform is not
        // applied); its instance only places the model. finishAnimation() gives it its skin.
        if (scene_.meshes[mesh].skinned()) instance.transform = glm::mat4(1.0f);
        scene_.instances.push_back(instance);
      }
    }

    if (placeable) placeLight(node, transform);
    if (placeable) placeCamera(node, transform);

    if (node.mChildren != nullptr) {
      for (unsigned c = 0; c < node.mNumChildren; ++c) {
        if (node.mChildren[c] != nullptr)
          visit(*node.mChildren[c], transform, depth + 1, nodeIndex);
      }
    }
  }

  // One entry per scene light: whether its radius came from the file rather than a guess.
  const std::vector<bool>& radiusFromFile() const { return radiusFromFile_; }

  // After visit(): skinned instances get their skins (one per distinct joint list and inverse
  // bind matrices), and the file's animations are read against the node tree (for glTF, from
  // the file itself: `gltf`). Past a limit or a rule of scene/animation.h the model is refused,
  // naming it.
  void finishAnimation(const detail::GltfFile* gltf) {
    std::string reason;
    std::vector<int32_t> skinOfMesh(scene_.meshes.size(), -1);
    for (unsigned m = 0; m < meshIndex_.size(); ++m) {
      const uint32_t mesh = meshIndex_[m];
      if (mesh >= scene_.meshes.size() || !scene_.meshes[mesh].skinned()) continue;
      Skin skin;
      if (!detail::readSkin(*source_.mMeshes[m], nodesByName_, skin, reason)) {
        // A bone naming no node (Assimp's X importer does this): the mesh is drawn unskinned,
        // placed by its node as before skins were read, rather than refused.
        scene_.meshes[mesh].joints.clear();
        scene_.meshes[mesh].weights.clear();
        for (Instance& instance : scene_.instances) {
          if (instance.mesh == mesh && instance.node >= 0) {
            instance.transform = nodeWorld_[size_t(instance.node)];
          }
        }
        continue;
      }
      int32_t index = -1;
      for (size_t s = 0; s < scene_.skins.size() && index < 0; ++s) {
        if (scene_.skins[s].joints == skin.joints &&
            scene_.skins[s].inverseBind == skin.inverseBind) {
          index = int32_t(s);
        }
      }
      if (index < 0) {
        if (scene_.skins.size() >= kMaxSkins) {
          fail(name_, "it has more than " + std::to_string(kMaxSkins) + " skins");
        }
        skin.name = "skin " + std::to_string(scene_.skins.size());
        index = int32_t(scene_.skins.size());
        scene_.skins.push_back(std::move(skin));
      }
      skinOfMesh[mesh] = index;
    }
    for (Instance& instance : scene_.instances) instance.skin = skinOfMesh[instance.mesh];
    if (!detail::readAnimations(source_, nodesByName_, scene_, scene_.animations, reason)) {
      fail(name_, reason);
    }
    if (gltf != nullptr) {
      if (const std::optional<std::string> refused = detail::readGltfAnimations(*gltf, scene_)) {
        fail(name_, *refused);
      }
    }
    if (const std::optional<std::string> problem = checkAnimationData(scene_))
      fail(name_, *problem);
  }

 private:
  // Keeps `node` in Scene::nodes (its transform as translation, rotation, scale: a sheared or
  // non-finite matrix keeps what decomposes, or identity), parents before children.
  int32_t addNode(const aiNode& source, int32_t parent) {
    if (scene_.nodes.size() >= kMaxNodes) {
      fail(name_, "it has more than " + std::to_string(kMaxNodes) + " nodes");
    }
    Node node;
    node.name = source.mName.C_Str();
    node.parent = parent;
    aiVector3D scale, position;
    aiQuaternion rotation;
    source.mTransformation.Decompose(scale, rotation, position);
    const glm::quat q(rotation.w, rotation.x, rotation.y, rotation.z);
    if (isFinite(scale) && isFinite(position) && std::isfinite(q.w + q.x + q.y + q.z) &&
        glm::length(q) > 1e-12f) {
      node.translation = {position.x, position.y, position.z};
      node.rotation = glm::normalize(q);
      node.scale = {scale.x, scale.y, scale.z};
    }
    const int32_t index = int32_t(scene_.nodes.size());
    nodesByName_.emplace(node.name, uint32_t(index));
    scene_.nodes.push_back(std::move(node));
    return index;
  }

  static constexpr uint32_t kUnconverted = UINT32_MAX;
  static constexpr uint32_t kNoTriangles = UINT32_MAX - 1;

  // Meshes are converted on first use, so ones no node places cost nothing and add nothing.
  uint32_t meshFor(unsigned sourceMesh) {
    uint32_t& index = meshIndex_[sourceMesh];
    if (index == kUnconverted) {
      const aiMesh& source = *source_.mMeshes[sourceMesh];
      detail::SourceVertices sourceOf;
      const aiMaterial* material =
          source_.mMaterials != nullptr && source.mMaterialIndex < source_.mNumMaterials
              ? source_.mMaterials[source.mMaterialIndex]
              : nullptr;
      // readMaterialExtras reads normal maps of glTF files only. The tangents follow the map's
      // KHR_texture_transform as the shader applies it (render/scene_upload.cpp), as the
      // per-pixel frame does: a rotated map rotates its frame.
      std::optional<glm::mat2> normalMapUv;
      if (isGltf(name_) && material != nullptr &&
          material->GetTextureCount(aiTextureType_NORMALS) > 0) {
        TextureRef map;
        readTextureTransform(*material, aiTextureType_NORMALS, map);
        const float c = std::cos(map.rotation), s = std::sin(map.rotation);
        normalMapUv = glm::mat2(c * map.scale.x, -s * map.scale.x, s * map.scale.y, c * map.scale.y);
      }
      Mesh mesh = convertMesh(source, sourceMesh, sourceOf, normalMapUv);
      std::string reason;
      if (!detail::readSkinWeights(source, sourceOf, mesh, reason) ||
          !detail::readMorphTargets(source, sourceOf, mesh, reason)) {
        fail(name_, reason);
      }
      if (mesh.indices.empty()) {
        index = kNoTriangles;
      } else {
        index = uint32_t(scene_.meshes.size());
        scene_.meshes.push_back(std::move(mesh));
      }
    }
    return index;
  }

  uint32_t materialFor(unsigned sourceMaterial) {
    if (sourceMaterial < scene_.materials.size() && sourceMaterial != defaultMaterial_) {
      return sourceMaterial;
    }
    // Assimp always gives a mesh a material, but a broken file can index past the list.
    if (defaultMaterial_ == kUnconverted) {
      defaultMaterial_ = uint32_t(scene_.materials.size());
      scene_.materials.push_back(Material{"default", {}, 0.0f, 0.5f});
    }
    return defaultMaterial_;
  }

  void placeLight(const aiNode& node, const glm::mat4& transform) {
    auto it = lightsByNode_.find(std::string(node.mName.C_Str()));
    if (it == lightsByNode_.end()) return;
    const aiLight& source = *it->second;
    // Placed once: glTF names need not be unique, and a light belongs to the first node naming it.
    lightsByNode_.erase(it);
    if (source.mType == aiLightSource_DIRECTIONAL) {
      placeSun(source, transform);
      return;
    }
    if (source.mType != aiLightSource_POINT && source.mType != aiLightSource_SPOT) return;

    // Assimp hands over colour already multiplied by intensity; split it back so the colour is at
    // most 1 in its brightest channel and the intensity carries the rest.
    const aiColor3D& c = source.mColorDiffuse;
    const float intensity = std::max({c.r, c.g, c.b});
    if (!std::isfinite(intensity) || intensity <= 0.0f) return;
    PointLight light;
    light.color = glm::vec3(c.r, c.g, c.b) / intensity;
    light.intensity = std::min(intensity, kMaxLightIntensity);
    // glTF's falloff: Assimp sets attenuation (0, 0, 1), i.e. 1/d^2, and keeps `range` aside.
    light.attenuation = Attenuation::InverseSquare;
    const glm::vec4 position =
        transform * glm::vec4(source.mPosition.x, source.mPosition.y, source.mPosition.z, 1.0f);
    light.position = glm::vec3(position);
    if (!std::isfinite(light.position.x + light.position.y + light.position.z)) return;
    if (source.mType == aiLightSource_SPOT) {
      // glTF: a spot points along its node's -Z (Assimp's mDirection, (0, 0, -1)), and its cone
      // angles are measured from that axis. Assimp's glTF 2 importer copies innerConeAngle and
      // outerConeAngle into mAngleInnerCone/mAngleOuterCone unchanged (aiLight's comment speaks
      // of the full cone angle; for glTF they are these half angles).
      const glm::vec3 direction =
          glm::mat3(transform) * glm::vec3(source.mDirection.x, source.mDirection.y, source.mDirection.z);
      const float length = glm::length(direction);
      if (!std::isfinite(length) || length < 1e-12f) return;
      light.type = LightType::Spot;
      light.direction = direction / length;
      const float outer = source.mAngleOuterCone, inner = source.mAngleInnerCone;
      // The spec's ranges (0 <= inner < outer <= pi/2), enforced on what a file may break.
      light.outerConeAngle = std::isfinite(outer) ? std::clamp(outer, 1e-4f, kMaxConeAngle)
                                                  : 0.78539816339744831f;
      light.innerConeAngle = std::isfinite(inner) ? std::clamp(inner, 0.0f, light.outerConeAngle) : 0.0f;
      if (!(light.innerConeAngle < light.outerConeAngle)) {
        light.innerConeAngle = std::nextafter(light.outerConeAngle, 0.0f);
      }
    }

    // glTF's `range` arrives as node metadata (float or double, depending on the Assimp build).
    float range = 0.0f;
    if (node.mMetaData != nullptr) {
      double asDouble = 0.0;
      if (!node.mMetaData->Get("PBR_LightRange", range) &&
          node.mMetaData->Get("PBR_LightRange", asDouble)) {
        range = float(asDouble);
      }
    }
    light.radius = std::min(
        std::isfinite(range) && range > 0.0f ? range : std::sqrt(intensity / kLightCutoff),
        kMaxLightRadius);
    radiusFromFile_.push_back(std::isfinite(range) && range > 0.0f);
    scene_.lights.push_back(light);
  }

  // glTF: a directional light shines along its node's -Z (Assimp's mDirection), intensity in lux;
  // colour and intensity are split as for point lights.
  void placeSun(const aiLight& source, const glm::mat4& transform) {
    const aiColor3D& c = source.mColorDiffuse;
    const float intensity = std::max({c.r, c.g, c.b});
    if (!std::isfinite(intensity) || intensity <= 0.0f) return;
    const glm::vec3 direction =
        glm::mat3(transform) * glm::vec3(source.mDirection.x, source.mDirection.y, source.mDirection.z);
    const float length = glm::length(direction);
    if (!std::isfinite(length) || length < 1e-12f) return;
    Sun sun;
    sun.direction = direction / length;
    sun.color = glm::vec3(c.r, c.g, c.b) / intensity;
    sun.intensity = std::min(intensity, kMaxSunIntensity);
    suns_.push_back(sun);
  }

  // glTF: a camera looks along its node's -Z with +Y up (Assimp's mLookAt and mUp, in the node's
  // space). Assimp 5.2.5 keeps glTF's znear and aspectRatio (0 when absent), zfar (100 when
  // absent: an infinite far plane does not survive it) and stores yfov * aspectRatio (yfov alone
  // without an aspect ratio) as mHorizontalFOV; yfov is recovered from that (the scene test
  // checks it on a file with aspect 1.5).
  void placeCamera(const aiNode& node, const glm::mat4& transform) {
    auto it = camerasByNode_.find(std::string(node.mName.C_Str()));
    if (it == camerasByNode_.end()) return;
    const unsigned index = it->second;
    camerasByNode_.erase(it);
    const aiCamera& source = *source_.mCameras[index];
    ModelCamera camera;
    camera.name = source.mName.C_Str();
    const glm::mat3 linear(transform);
    // Assimp 5.2.5's glTF 2 importer also copies the node's translation into mPosition, which the
    // node transform then applies a second time (the cameras test file would put its camera at
    // twice its place): a position equal to the node's own translation is taken as that copy.
    glm::vec3 local(source.mPosition.x, source.mPosition.y, source.mPosition.z);
    const aiMatrix4x4& own = node.mTransformation;
    if (local == glm::vec3(own.a4, own.b4, own.c4)) local = glm::vec3(0.0f);
    camera.position = glm::vec3(transform * glm::vec4(local, 1.0f));
    glm::vec3 direction = linear * glm::vec3(source.mLookAt.x, source.mLookAt.y, source.mLookAt.z);
    glm::vec3 up = linear * glm::vec3(source.mUp.x, source.mUp.y, source.mUp.z);
    // Up made perpendicular to the direction (a sheared node transform may tilt it).
    up = up - direction * (glm::dot(up, direction) / std::max(glm::dot(direction, direction), 1e-30f));
    const float directionLength = glm::length(direction), upLength = glm::length(up);
    if (!(directionLength > 1e-12f && upLength > 1e-12f) || !std::isfinite(directionLength + upLength) ||
        !std::isfinite(camera.position.x + camera.position.y + camera.position.z)) {
      return;
    }
    camera.direction = direction / directionLength;
    camera.up = up / upLength;
    camera.perspective = source.mOrthographicWidth == 0.0f;
    const float aspect = source.mAspect;
    camera.aspectRatio = std::isfinite(aspect) && aspect > 0.0f && aspect <= 1e6f ? aspect : 0.0f;
    const float horizontal = source.mHorizontalFOV;
    float yfov = camera.aspectRatio > 0.0f ? horizontal / camera.aspectRatio : horizontal;
    if (!camera.perspective) yfov = 0.0f;
    if (!std::isfinite(yfov) || yfov < 0.0f || yfov > 3.2f) return;
    if (camera.perspective && yfov <= 0.0f) return;
    camera.yfov = yfov;
    const float znear = source.mClipPlaneNear, zfar = source.mClipPlaneFar;
    if (!std::isfinite(znear) || !(znear > 0.0f) || !std::isfinite(zfar) || zfar < 0.0f) return;
    camera.znear = znear;
    camera.zfar = zfar > znear ? zfar : 0.0f;
    placedCameras_[index] = std::move(camera);
  }

  const aiScene& source_;
  const std::string& name_;
  Scene& scene_;
  std::vector<uint32_t> meshIndex_;
  std::unordered_multimap<std::string, const aiLight*> lightsByNode_;
  std::unordered_multimap<std::string, unsigned> camerasByNode_;
  std::vector<std::optional<ModelCamera>> placedCameras_;
  std::vector<Sun> suns_;
  uint32_t defaultMaterial_ = kUnconverted;
  size_t visits_ = 0;
  std::unordered_multimap<std::string, uint32_t> nodesByName_;
  std::vector<glm::mat4> nodeWorld_;  // per node, its world transform as loaded
  std::vector<bool> radiusFromFile_;
};

// Drops materials no instance uses (glTF files gain an unused Assimp default, OBJ libraries list
// whole catalogues), so the material panel shows only what is on screen.
void dropUnusedMaterials(Scene& scene) {
  std::vector<uint32_t> remap(scene.materials.size(), UINT32_MAX);
  std::vector<Material> used;
  for (Instance& instance : scene.instances) {
    uint32_t& index = remap[instance.material];
    if (index == UINT32_MAX) {
      index = uint32_t(used.size());
      used.push_back(scene.materials[instance.material]);
    }
    instance.material = index;
  }
  scene.materials = std::move(used);
}

// glTF lights follow the inverse-square law and arrive with Attenuation::InverseSquare, cut at the
// file's `range` or, without one, where their illuminance falls to kLightCutoff. A light without
// a range has none in glTF (pure 1/d^2), and the renderer needs one (its lists are by volume), so
// a guessed radius lies between kRangelessReach and kRangelessCap model sizes: the spec's falloff
// within 1% out to twice the model's size from the light (the window (1 - (d/r)^4)^2 is 0.992 at
// d = r/4), while one bright light still does not make every tile of
// a far larger view shade it. The window's C is set too, to r^2 (where (r^2 - d^2) / (C d^2 + r^2)
// approximates 1 / (1 + d^2) * (1 - d^2 / r^2)), for a user who switches a light to "window".
constexpr float kRangelessReach = 8.0f;
constexpr float kRangelessCap = 16.0f;
void fitLightFalloff(Scene& scene, const std::vector<bool>& radiusGiven, float sceneSize) {
  const float size = std::max(sceneSize, 1e-3f);
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    PointLight& light = scene.lights[i];
    if (!radiusGiven[i]) {
      light.radius = std::min(std::clamp(light.radius, kRangelessReach * size, kRangelessCap * size),
                              kMaxLightRadius);
    }
    light.falloff = std::min(light.radius * light.radius, kMaxLightFalloff);
  }
}

// A whole file through the importer's IOSystem (so confined as Assimp's own reads), or nothing.
std::optional<std::string> readThrough(Assimp::IOSystem& io, const std::string& path) {
  if (!io.Exists(path.c_str())) return std::nullopt;
  std::unique_ptr<Assimp::IOStream, std::function<void(Assimp::IOStream*)>> stream(
      io.Open(path.c_str(), "rb"), [&io](Assimp::IOStream* s) { io.Close(s); });
  if (!stream) return std::nullopt;
  std::string bytes(stream->FileSize(), '\0');
  if (!bytes.empty() && stream->Read(bytes.data(), 1, bytes.size()) != bytes.size()) {
    return std::nullopt;
  }
  return bytes;
}

bool isGltf(const std::string& name) {
  const std::string extension = lowerExtension(std::filesystem::path(name).extension().string());
  return extension == "gltf" || extension == "glb";
}

// Turns what Assimp read (`raw`: validated, not yet post-processed) into a Scene. Images are read
// through `io` (null: none can be), relative to `directory` (a path `io` understands).
Scene convertImport(Assimp::Importer& importer, const aiScene* raw, const std::string& name,
                    Assimp::IOSystem* io, const std::string& directory,
                    const detail::GltfFile* gltf) {
  bool anyTriangles = false;
  bool anyNonFinite = false;
  for (unsigned m = 0; raw->mMeshes != nullptr && m < raw->mNumMeshes; ++m) {
    const aiMesh* mesh = raw->mMeshes[m];
    if (mesh == nullptr || mesh->mVertices == nullptr) continue;
    anyTriangles = anyTriangles ||
                   (mesh->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON));
    for (unsigned v = 0; v < mesh->mNumVertices && !anyNonFinite; ++v) {
      anyNonFinite = !isFinite(mesh->mVertices[v]);
    }
  }
  const std::string nonFinite = "its meshes have non-finite (NaN or infinite) vertex positions";
  const std::string noTriangles = "it contains no triangle meshes";
  // Assimp 5.2's JoinIdenticalVertices merges vertices that differ only in their bone weights
  // or morph displacements (a seam's two sides then bend or morph together): a model with skins
  // or morph targets keeps its vertices as the file has them (glTF's are indexed already).
  bool anyDeforming = false;
  for (unsigned m = 0; raw->mMeshes != nullptr && m < raw->mNumMeshes && !anyDeforming; ++m) {
    const aiMesh* mesh = raw->mMeshes[m];
    anyDeforming = mesh != nullptr && (mesh->mNumBones > 0 || mesh->mNumAnimMeshes > 0);
  }
  const aiScene* source = importer.ApplyPostProcessing(
      anyDeforming ? kPostProcess & ~unsigned(aiProcess_JoinIdenticalVertices) : kPostProcess);
  if (source == nullptr) {
    // Assimp's reason here is "No meshes remaining" whether it dropped points, lines, degenerate
    // triangles or non-finite meshes; what was seen before post-processing says which.
    if (anyNonFinite) fail(name, nonFinite, Kind::empty);
    if (!anyTriangles) fail(name, noTriangles + " (only points or lines)", Kind::empty);
    fail(name, noTriangles + " (" + importer.GetErrorString() + ")", Kind::empty);
  }

  Scene scene;
  scene.materials.reserve(source->mNumMaterials);
  for (unsigned i = 0; source->mMaterials != nullptr && i < source->mNumMaterials; ++i) {
    scene.materials.push_back(source->mMaterials[i] != nullptr
                                  ? convertMaterial(*source->mMaterials[i], i)
                                  : Material{"material " + std::to_string(i)});
  }
  Flattener flattener(*source, name, scene);
  if (source->mRootNode != nullptr) flattener.visit(*source->mRootNode, glm::mat4(1.0f), 0);
  flattener.finish();
  flattener.finishAnimation(isGltf(name) ? gltf : nullptr);

  if (scene.instances.empty()) {
    fail(name, anyNonFinite ? nonFinite : noTriangles, Kind::empty);
  }
  // Images only for the materials something is drawn with (after the walk, so unused materials'
  // images are neither read nor counted against the limits).
  {
    std::vector<bool> used(scene.materials.size(), false);
    for (const Instance& instance : scene.instances) used[instance.material] = true;
    ImageCollector images(*source, io, directory, isGltf(name), name, scene);
    for (unsigned i = 0; i < source->mNumMaterials && i < scene.materials.size(); ++i) {
      if (used[i] && source->mMaterials[i] != nullptr) {
        readMaterialExtras(*source->mMaterials[i], isGltf(name), images, scene.materials[i]);
      }
    }
  }
  // What Assimp does not read of a glTF's materials, from the file itself (gltf_materials.h).
  if (isGltf(name) && gltf != nullptr) {
    std::vector<std::string> assimpNames;
    for (unsigned i = 0; i < source->mNumMaterials && i < scene.materials.size(); ++i) {
      aiString materialName;
      const bool named = source->mMaterials[i] != nullptr &&
                         source->mMaterials[i]->Get(AI_MATKEY_NAME, materialName) == AI_SUCCESS;
      assimpNames.push_back(named ? std::string(materialName.C_Str()) : std::string());
    }
    detail::readGltfMaterialExtensions(*gltf, assimpNames, scene.materials,
                                       scene.ignoredExtensions);
  }
  const Bounds bounds = scene.bounds();
  const glm::vec3 size = bounds.size();
  if (!std::isfinite(size.x + size.y + size.z) || !std::isfinite(glm::length(size))) {
    fail(name, "its coordinates are too large to render");
  }
  dropUnusedMaterials(scene);
  fitLightFalloff(scene, flattener.radiusFromFile(), glm::length(size));
  // Framed as drawn: skinned meshes placed by their joints at rest, not in their bind space.
  if (animated(scene)) {
    const Bounds posed = posedBounds(scene, -1, 0.0, false);
    const glm::vec3 posedSize = posed.size();
    const bool usable = !posed.empty() && std::isfinite(glm::length(posedSize));
    scene.camera = frameBounds(usable ? posed : bounds);
  } else {
    scene.camera = frameBounds(bounds);
  }
  return scene;
}

}  // namespace

Scene loadModel(const std::filesystem::path& path) {
  const std::string name = path.filename().string();
  std::error_code error;
  if (!std::filesystem::exists(path, error)) fail(name, "the file does not exist");
  if (!std::filesystem::is_regular_file(path, error)) fail(name, "it is not a regular file");
  const std::filesystem::path absolute = std::filesystem::weakly_canonical(path, error);
  if (error) fail(name, "its path cannot be resolved (" + error.message() + ")");

  Assimp::Importer importer;
  configure(importer);
  importer.SetIOHandler(new ConfinedIOSystem(absolute.parent_path()));  // the importer owns it
  // Two phases so that the raw import can be inspected before post-processing deletes the evidence:
  // validation first (indices in range, counts consistent), then the steps above.
  const aiScene* raw = importer.ReadFile(absolute.string(), aiProcess_ValidateDataStructure);
  if (raw == nullptr) fail(name, importer.GetErrorString());
  Assimp::IOSystem* io = importer.GetIOHandler();
  const std::string folder = absolute.parent_path().string();
  // The file again for what Assimp does not read: its material extensions (gltf_materials.h)
  // and its animations' samplers (gltf_animation.h).
  const std::string own = isGltf(name) ? readThrough(*io, absolute.string()).value_or("") : "";
  const detail::GltfFile gltf{
      own, lowerExtension(absolute.extension().string()) == "glb",
      [io, folder](const std::string& uri) { return readThrough(*io, folder + "/" + uri); }};
  return convertImport(importer, raw, name, io, folder, &gltf);
}

Scene loadModelFromMemory(std::string_view bytes, std::string_view filename) {
  const std::string name = std::filesystem::path(filename).filename().string();
  const std::string hint = lowerExtension(std::filesystem::path(filename).extension().string());
  if (hint.empty()) {
    fail(name, "the file name has no extension to tell its format", Kind::unsupported);
  }
  if (!isSupportedModelExtension(hint)) {
    fail(name, "'." + hint + "' is not a model format this server reads", Kind::unsupported);
  }
  if (bytes.empty()) fail(name, "the file is empty", Kind::empty);

  Assimp::Importer importer;
  configure(importer);
  // Assimp's memory reader passes every name but the buffer's own to this handler; with no root
  // it refuses them all, so an upload reads nothing but its own bytes.
  auto* io = new ConfinedIOSystem({});
  importer.SetIOHandler(io);  // the importer owns it
  const aiScene* raw = importer.ReadFileFromMemory(bytes.data(), bytes.size(),
                                                   aiProcess_ValidateDataStructure, hint.c_str());
  if (raw == nullptr) {
    if (!io->refused().empty()) {
      fail(name,
           "it refers to the separate file '" +
               std::filesystem::path(io->refused().front()).filename().string() +
               "', which an upload cannot carry (send a .glb or a .gltf with embedded data, or "
               "put the files in the model library)",
           Kind::unsupported);
    }
    fail(name, importer.GetErrorString());
  }
  const detail::GltfFile gltf{bytes, hint == "glb", nullptr};
  return convertImport(importer, raw, name, nullptr, "", &gltf);
}

Scene loadModelFromFiles(const MemoryFiles& files, std::string_view entry) {
  const std::string name = std::filesystem::path(entry).filename().string();
  const std::string* bytes = findMember(files, entry);
  if (bytes == nullptr) fail(name, "the upload holds no such file", Kind::unsupported);
  if (!isSupportedModelExtension(std::filesystem::path(entry).extension().string())) {
    fail(name, "it is not in a model format this server reads", Kind::unsupported);
  }
  if (bytes->empty()) fail(name, "the file is empty", Kind::empty);

  Assimp::Importer importer;
  configure(importer);
  auto* io = new MemberIOSystem(files);
  importer.SetIOHandler(io);  // the importer owns it
  const aiScene* raw = importer.ReadFile(std::string(entry), aiProcess_ValidateDataStructure);
  if (raw == nullptr) {
    if (!io->refused().empty()) {
      fail(name, "it refers to the file '" + io->refused().front() +
                     "', which the upload does not hold (" + importer.GetErrorString() + ")");
    }
    fail(name, importer.GetErrorString());
  }
  const std::string folder = std::filesystem::path(std::string(entry)).parent_path().generic_string();
  const detail::GltfFile gltf{
      *bytes, lowerExtension(std::filesystem::path(entry).extension().string()) == "glb",
      [&files, folder](const std::string& uri) -> std::optional<std::string> {
        const std::string* member = findMember(files, folder.empty() ? uri : folder + "/" + uri);
        if (member == nullptr) return std::nullopt;
        return *member;
      }};
  return convertImport(importer, raw, name, importer.GetIOHandler(), folder, &gltf);
}

bool isSupportedModelExtension(std::string_view extension) {
  // Asked once per file of a library listing, so the list is built once (thread-safe static).
  static const std::vector<std::string> supported = [] {
    Assimp::Importer importer;
    std::string list;  // "*.3ds;*.obj;..."
    importer.GetExtensionList(list);
    std::vector<std::string> extensions;
    size_t start = 0;
    while (start < list.size()) {
      size_t end = list.find(';', start);
      if (end == std::string::npos) end = list.size();
      std::string_view item(list.data() + start, end - start);
      if (item.substr(0, 2) == "*.") extensions.push_back(lowerExtension(item.substr(2)));
      start = end + 1;
    }
    std::sort(extensions.begin(), extensions.end());
    return extensions;
  }();
  const std::string lower = lowerExtension(extension);
  return !lower.empty() && std::binary_search(supported.begin(), supported.end(), lower);
}

}  // namespace myriad::scene
