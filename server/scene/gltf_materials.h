// glTF material extensions read from the file itself (model_loader.cpp's helper, private to
// scene/). Debian's Assimp 5.2.5 never reads KHR_materials_emissive_strength, _unlit's meaning,
// _ior or _specular (it has keys for _clearcoat and _sheen, but they are read here with the rest,
// from the same matched material); what it does not read, the loader reads from the JSON here,
// after Assimp's materials are converted, and names every extension the file uses that Myriad
// does not honour, so that the model summary can say so (Scene::ignoredExtensions).
#pragma once

#include <string>
#include <vector>

#include "scene/gltf_animation.h"
#include "scene/scene.h"

namespace myriad::scene::detail {

// The extensions a glTF file may use that Myriad honours (every other one it names in
// extensionsUsed, or on a material, is listed as ignored).
const std::vector<std::string>& supportedGltfExtensions();

// Applies the file's KHR_materials_emissive_strength, _unlit, _ior, _specular, _clearcoat and
// _sheen (factors) and every texture slot's KHR_texture_transform to `materials` (Assimp's,
// converted: `assimpNames[i]` is the name Assimp gave materials[i], empty when it gave none;
// Assimp orders materials as it first meets them, not as the file lists them, so they are matched
// by name, then by factors), and sets `ignored` to the extensions used but not honoured and the
// parts of honoured ones a material uses but Myriad does not read ("KHR_materials_sheen
// (sheenColorTexture)"), sorted. A file whose JSON cannot be read
// changes nothing (Assimp read it, so this is an approximation at worst).
void readGltfMaterialExtensions(const GltfFile& file, const std::vector<std::string>& assimpNames,
                                std::vector<Material>& materials, std::vector<std::string>& ignored);

}  // namespace myriad::scene::detail
