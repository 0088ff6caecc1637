// Several files held in memory under relative paths: a model uploaded together with the files it
// refers to (a .gltf with its .bin and images, an .obj with its .mtl), as the loader child unpacks
// them from a zip archive or a multipart upload. Nothing here touches the file system.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace myriad::scene {

// Member path ("textures/wood.png") -> bytes. Paths are normalized (normalizeMemberPath).
using MemoryFiles = std::map<std::string, std::string, std::less<>>;

// `path` as a member path: separators '/' (a '\' counts as one, as in models made on Windows),
// no empty, "." or ".." segments (a ".." takes back the segment before it). nullopt when nothing
// is left, or the path is absolute, climbs above the set's root, or holds a control character.
std::optional<std::string> normalizeMemberPath(std::string_view path);

// The member `path` names (normalized), else the one member whose path matches it ignoring ASCII
// case (files named on Windows), else nullptr.
const std::string* findMember(const MemoryFiles& files, std::string_view path,
                              std::string* foundPath = nullptr);

// The set's model file: `entry` when given (throws ModelLoadError unsupported when the set has no
// such member), else the one member whose extension is a model format Assimp reads and is not a
// file other models refer to (.bin, .mtl, images). Throws ModelLoadError (unsupported) naming the
// candidates when there are none or several. `name` names the upload in messages.
std::string modelEntryOf(const MemoryFiles& files, std::string_view entry, std::string_view name);

}  // namespace myriad::scene
