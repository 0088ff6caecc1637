// The loader's animation part (model_loader.cpp's helper; Assimp-facing, private to scene/):
// skins, morph targets and animation channels read from what Assimp imported.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "scene/scene.h"

struct aiMesh;
struct aiScene;

namespace myriad::scene::detail {

// Per converted vertex, the vertex of the source mesh it came from.
using SourceVertices = std::vector<uint32_t>;

// Reads `source`'s morph targets into `mesh`: Assimp's glTF importer stores each target's
// positions, normals and tangents as absolute values (rest + displacement); they are turned back
// into displacements. Returns false (and sets `reason`) past kMaxMorphTargets.
bool readMorphTargets(const aiMesh& source, const SourceVertices& sourceOf, Mesh& mesh,
                      std::string& reason);

// Reads `source`'s bone weights into `mesh` as up to four (joint, weight) pairs per vertex,
// joints indexing `source`'s bones in order (the four largest weights kept, normalised; a vertex
// no bone weights is bound wholly to joint 0). Returns false past kMaxJointsPerSkin.
bool readSkinWeights(const aiMesh& source, const SourceVertices& sourceOf, Mesh& mesh,
                     std::string& reason);

// The skin of `source`'s bones: each bone's node (by name in `nodesByName`, the first node of
// that name) and its offset matrix as the inverse bind matrix. Returns false when a bone names
// no node (the loader then draws that mesh unskinned).
bool readSkin(const aiMesh& source,
              const std::unordered_multimap<std::string, uint32_t>& nodesByName, Skin& skin,
              std::string& reason);

// Every animation of `source`: node channels (translation, rotation, scale; Assimp's glTF
// importer keeps no interpolation mode, so linear) and morph-weight channels, times in seconds.
// Channels naming no node are dropped. Returns false with `reason` past a limit.
bool readAnimations(const aiScene& source,
                    const std::unordered_multimap<std::string, uint32_t>& nodesByName,
                    const Scene& scene, std::vector<Animation>& animations, std::string& reason);

}  // namespace myriad::scene::detail
