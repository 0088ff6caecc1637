#pragma once

#include <filesystem>
#include <stdexcept>

#include "scene/scene.h"

namespace myriad::scene {

// Why a model could not be loaded, in one sentence a user can act on.
class ModelLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Loads any format Assimp reads: meshes (triangulated, normals generated where missing), material
// factors (base colour, metallic, roughness), node transforms, and glTF KHR_lights_punctual point
// lights. Sets a camera framing the model. Throws ModelLoadError with the reason.
Scene loadModel(const std::filesystem::path& path);

}  // namespace myriad::scene
