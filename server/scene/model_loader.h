#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "scene/memory_files.h"
#include "scene/scene.h"

namespace myriad::scene {

// Why a model could not be loaded, in one sentence a user can act on.
class ModelLoadError : public std::runtime_error {
 public:
  enum class Kind {
    parse,        // Assimp could not read it, or what it read is inconsistent
    empty,        // it read, but holds nothing the renderer draws
    unsupported,  // a format Assimp does not read, or an upload naming files it cannot carry
    tooLarge,     // an archive over a limit (entries, bytes, compression ratio), named in the sentence
  };

  explicit ModelLoadError(const std::string& sentence, Kind kind = Kind::parse)
      : std::runtime_error(sentence), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// Loads any format Assimp reads: meshes (triangulated, normals generated where missing), material
// factors (base colour, metallic, roughness), node transforms, and glTF KHR_lights_punctual point
// lights. Sets a camera framing the model. Throws ModelLoadError with the reason.
// Files the model refers to (a glTF's .bin, an OBJ's .mtl) are read only from the model's own
// directory and below.
Scene loadModel(const std::filesystem::path& path);

// The same from bytes already in memory (an upload). `filename`'s extension is the format hint and
// names the model in messages. No other file is read: a model that refers to one (a .gltf with an
// external .bin) is rejected with Kind::unsupported.
Scene loadModelFromMemory(std::string_view bytes, std::string_view filename);

// The same from several files in memory (an upload of a model with the files it refers to):
// `entry` (a member path, see memory_files.h) is the model; the files it refers to are read only
// from `files`, relative to the entry's folder. A reference to a file the set lacks, or one that
// leaves the set (an absolute path, ".." above its root), is a parse error naming the file.
Scene loadModelFromFiles(const MemoryFiles& files, std::string_view entry);

// Whether Assimp reads files with this extension (".glb" or "glb", any case).
bool isSupportedModelExtension(std::string_view extension);

}  // namespace myriad::scene
