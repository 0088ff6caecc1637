#include "scene/gltf_materials.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

namespace myriad::scene::detail {

namespace {

using nlohmann::json;

// What a hostile file can put into the summary: at most this many names, each at most this long
// and printable ASCII (glTF extension names are identifiers: "KHR_materials_sheen").
constexpr size_t kMaxIgnoredExtensions = 32;
constexpr size_t kMaxExtensionNameBytes = 64;
// What a file may set a texture transform's numbers to: TextureRef's own bounds.
constexpr float kMaxTransformValue = 1e6f;

// The file's JSON document, or a discarded value (.gltf: all of it; .glb: its JSON chunk).
json parseDocument(const GltfFile& file) {
  std::string_view text = file.bytes;
  if (file.binary) {
    auto u32 = [&](size_t at) {
      uint32_t v = 0;
      if (at + 4 <= file.bytes.size()) std::memcpy(&v, file.bytes.data() + at, 4);
      return v;
    };
    if (file.bytes.size() < 20 || u32(0) != 0x46546C67u || u32(16) != 0x4E4F534Au ||
        u32(12) > file.bytes.size() - 20) {
      return json(json::value_t::discarded);
    }
    text = file.bytes.substr(20, u32(12));
  }
  return json::parse(text, nullptr, false);
}

const json* member(const json& object, const char* name) {
  if (!object.is_object()) return nullptr;
  auto it = object.find(name);
  return it == object.end() ? nullptr : &*it;
}

const json* extension(const json& object, const char* name) {
  const json* extensions = member(object, "extensions");
  return extensions != nullptr ? member(*extensions, name) : nullptr;
}

std::optional<float> finiteNumber(const json* value) {
  if (value == nullptr || !value->is_number()) return std::nullopt;
  const double v = value->get<double>();
  if (!std::isfinite(v)) return std::nullopt;
  return float(std::clamp(v, double(-kMaxTransformValue), double(kMaxTransformValue)));
}

std::optional<glm::vec2> finitePair(const json* value) {
  if (value == nullptr || !value->is_array() || value->size() != 2) return std::nullopt;
  const std::optional<float> x = finiteNumber(&(*value)[0]), y = finiteNumber(&(*value)[1]);
  if (!x || !y) return std::nullopt;
  return glm::vec2(*x, *y);
}

// A textureInfo's KHR_texture_transform (offset, rotation, scale) onto `ref`. Members that are
// absent keep the extension's defaults. Its texCoord, like the textureInfo's own, is not carried:
// vertices hold texture coordinate set 0 only (TextureRef::texCoord stays 0, as the wire demands).
void readTransform(const json& textureInfo, TextureRef& ref) {
  const json* t = extension(textureInfo, "KHR_texture_transform");
  if (t == nullptr || !t->is_object()) return;
  ref.offset = finitePair(member(*t, "offset")).value_or(glm::vec2(0.0f));
  ref.scale = finitePair(member(*t, "scale")).value_or(glm::vec2(1.0f));
  ref.rotation = finiteNumber(member(*t, "rotation")).value_or(0.0f);
}

std::optional<glm::vec3> finiteColor(const json* value) {
  if (value == nullptr || !value->is_array() || value->size() != 3) return std::nullopt;
  glm::vec3 color;
  for (int c = 0; c < 3; ++c) {
    const std::optional<float> v = finiteNumber(&(*value)[size_t(c)]);
    if (!v) return std::nullopt;
    color[c] = std::clamp(*v, 0.0f, 1.0f);
  }
  return color;
}

// KHR_materials_clearcoat's and KHR_materials_sheen's factors onto `material`. Their textures
// are not read: each one a material has is named in `partial` as "EXTENSION (member)", so that
// the summary says the picture lacks it.
void readLayers(const json& source, Material& material, std::set<std::string>& partial) {
  auto unread = [&](const json& ext, const char* extensionName, const char* texture) {
    if (const json* t = member(ext, texture); t != nullptr && t->is_object()) {
      partial.insert(std::string(extensionName) + " (" + texture + ")");
    }
  };
  auto unit = [](const json* value) {  // a factor in [0, 1], absent: the extensions' 0
    return std::clamp(finiteNumber(value).value_or(0.0f), 0.0f, 1.0f);
  };
  const json* coat = extension(source, "KHR_materials_clearcoat");
  if (coat != nullptr && coat->is_object()) {
    material.clearcoat = unit(member(*coat, "clearcoatFactor"));
    material.clearcoatRoughness = unit(member(*coat, "clearcoatRoughnessFactor"));
    for (const char* texture :
         {"clearcoatTexture", "clearcoatRoughnessTexture", "clearcoatNormalTexture"}) {
      unread(*coat, "KHR_materials_clearcoat", texture);
    }
  }
  const json* sheen = extension(source, "KHR_materials_sheen");
  if (sheen != nullptr && sheen->is_object()) {
    material.sheenColor = finiteColor(member(*sheen, "sheenColorFactor")).value_or(glm::vec3(0.0f));
    material.sheenRoughness = unit(member(*sheen, "sheenRoughnessFactor"));
    for (const char* texture : {"sheenColorTexture", "sheenRoughnessTexture"}) {
      unread(*sheen, "KHR_materials_sheen", texture);
    }
  }
}

void readMaterial(const json& source, Material& material, std::set<std::string>& partial) {
  readLayers(source, material, partial);
  if (const json* strength = extension(source, "KHR_materials_emissive_strength")) {
    if (const std::optional<float> value = finiteNumber(member(*strength, "emissiveStrength"))) {
      material.emissiveStrength = std::clamp(*value, 0.0f, 1e4f);
    }
  }
  if (const json* ior = extension(source, "KHR_materials_ior")) {
    // The spec allows [1, inf) (0 too, for "no dielectric reflection", not honoured here).
    if (const std::optional<float> value = finiteNumber(member(*ior, "ior")); value && *value >= 1.0f) {
      material.ior = std::min(*value, 10.0f);
    }
  }
  if (const json* specular = extension(source, "KHR_materials_specular")) {
    if (const std::optional<float> value = finiteNumber(member(*specular, "specularFactor"))) {
      material.specular = std::clamp(*value, 0.0f, 1.0f);
    }
  }
  const json* unlit = extension(source, "KHR_materials_unlit");
  material.unlit = unlit != nullptr && unlit->is_object();
  const json empty = json::object();
  const json* pbr = member(source, "pbrMetallicRoughness");
  const json& metallicRoughness = pbr != nullptr ? *pbr : empty;
  const std::pair<const json*, TextureRef*> slots[] = {
      {member(metallicRoughness, "baseColorTexture"), &material.baseColorTexture},
      {member(metallicRoughness, "metallicRoughnessTexture"), &material.metallicRoughnessTexture},
      {member(source, "normalTexture"), &material.normalTexture},
      {member(source, "occlusionTexture"), &material.occlusionTexture},
      {member(source, "emissiveTexture"), &material.emissiveTexture},
  };
  for (const auto& [info, ref] : slots) {
    if (info != nullptr && info->is_object()) readTransform(*info, *ref);
  }
}

std::string nameOf(const json& material) {
  const json* name = member(material, "name");
  return name != nullptr && name->is_string() ? name->get<std::string>() : std::string();
}

// Whether the file's material `source` has the factors Assimp gave `material` (what tells two
// unnamed materials apart): base colour, metallic and roughness, as convertMaterial clamps them.
bool sameFactors(const json& source, const Material& material) {
  const json empty = json::object();
  const json* pbr = member(source, "pbrMetallicRoughness");
  const json& p = pbr != nullptr ? *pbr : empty;
  glm::vec3 base(1.0f);
  if (const json* factor = member(p, "baseColorFactor");
      factor != nullptr && factor->is_array() && factor->size() == 4) {
    for (int c = 0; c < 3; ++c) {
      const std::optional<float> v = finiteNumber(&(*factor)[size_t(c)]);
      base[c] = std::clamp(v.value_or(1.0f), 0.0f, 1.0f);
    }
  }
  const float metallic = std::clamp(finiteNumber(member(p, "metallicFactor")).value_or(1.0f), 0.0f, 1.0f);
  const float roughness =
      std::clamp(finiteNumber(member(p, "roughnessFactor")).value_or(1.0f), 0.0f, 1.0f);
  auto near = [](float a, float b) { return std::abs(a - b) <= 1e-5f; };
  return near(base.r, material.baseColor.r) && near(base.g, material.baseColor.g) &&
         near(base.b, material.baseColor.b) && near(metallic, material.metallic) &&
         near(roughness, material.roughness);
}

// The file's material that Assimp's material `index` came from, or -1: the one of the same name
// when exactly one has it; for an unnamed one (or a name that no file material has), the file's material at the same index when its
// factors agree, else the one unnamed material whose factors do.
int64_t fileMaterialOf(const json& files, const std::vector<std::string>& fileNames,
                       const std::string& name, size_t index, const Material& material) {
  if (!name.empty()) {
    if (index < fileNames.size() && fileNames[index] == name) return int64_t(index);
    int64_t found = -1;
    for (size_t i = 0; i < fileNames.size(); ++i) {
      if (fileNames[i] != name) continue;
      if (found >= 0) return -1;  // two of that name, neither at this index: unknown
      found = int64_t(i);
    }
    // No file material of that name: a name Assimp made up for an unnamed one.
    if (found >= 0) return found;
  }
  if (index < fileNames.size() && fileNames[index].empty() && sameFactors(files[index], material)) {
    return int64_t(index);
  }
  int64_t found = -1;
  for (size_t i = 0; i < fileNames.size(); ++i) {
    if (!fileNames[i].empty() || !sameFactors(files[i], material)) continue;
    if (found >= 0) return -1;
    found = int64_t(i);
  }
  return found;
}

void addName(const json& value, std::set<std::string>& names) {
  if (!value.is_string()) return;
  const std::string& name = value.get_ref<const std::string&>();
  if (name.empty() || name.size() > kMaxExtensionNameBytes) return;
  if (!std::all_of(name.begin(), name.end(), [](char c) { return c > ' ' && c < 127; })) return;
  names.insert(name);
}

}  // namespace

const std::vector<std::string>& supportedGltfExtensions() {
  // KHR_lights_punctual and KHR_materials_pbrSpecularGlossiness (its diffuse and glossiness
  // factors, as the base colour and 1 - roughness) are read by Assimp; the rest here
  // (KHR_materials_specular: its specularFactor; its colour factor and textures are not read;
  // KHR_materials_clearcoat and _sheen: their factors; a texture of theirs that a material has is
  // listed as ignored by name, readLayers).
  static const std::vector<std::string> supported = {
      "KHR_lights_punctual", "KHR_materials_clearcoat", "KHR_materials_emissive_strength",
      "KHR_materials_ior", "KHR_materials_pbrSpecularGlossiness", "KHR_materials_sheen",
      "KHR_materials_specular", "KHR_materials_unlit", "KHR_texture_transform"};
  return supported;
}

void readGltfMaterialExtensions(const GltfFile& file, const std::vector<std::string>& assimpNames,
                                std::vector<Material>& materials, std::vector<std::string>& ignored) {
  ignored.clear();
  const json root = parseDocument(file);
  if (root.is_discarded() || !root.is_object()) return;

  std::set<std::string> used;
  std::set<std::string> partial;  // "EXTENSION (member)": an honoured extension's unread parts
  if (const json* list = member(root, "extensionsUsed"); list != nullptr && list->is_array()) {
    for (const json& name : *list) addName(name, used);
  }
  if (const json* list = member(root, "extensionsRequired"); list != nullptr && list->is_array()) {
    for (const json& name : *list) addName(name, used);
  }
  const json* files = member(root, "materials");
  if (files != nullptr && files->is_array()) {
    // Files do not always list what their materials use in extensionsUsed.
    for (const json& m : *files) {
      if (const json* extensions = member(m, "extensions"); extensions != nullptr && extensions->is_object()) {
        for (const auto& item : extensions->items()) addName(json(item.key()), used);
      }
    }
    std::vector<std::string> fileNames;
    fileNames.reserve(files->size());
    for (const json& m : *files) fileNames.push_back(nameOf(m));
    for (size_t i = 0; i < materials.size() && i < assimpNames.size(); ++i) {
      const int64_t source = fileMaterialOf(*files, fileNames, assimpNames[i], i, materials[i]);
      if (source >= 0 && (*files)[size_t(source)].is_object()) {
        readMaterial((*files)[size_t(source)], materials[i], partial);
      }
    }
  }
  const std::vector<std::string>& supported = supportedGltfExtensions();
  std::set<std::string> listed = partial;
  for (const std::string& name : used) {
    if (std::find(supported.begin(), supported.end(), name) == supported.end()) listed.insert(name);
  }
  for (const std::string& name : listed) {
    if (ignored.size() >= kMaxIgnoredExtensions) break;
    ignored.push_back(name);
  }
}

}  // namespace myriad::scene::detail
