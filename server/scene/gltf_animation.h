// glTF animations read from the file itself (model_loader.cpp's helper, private to scene/).
// Assimp 5.2's glTF 2 importer keeps each sampler's key values but not its interpolation: STEP
// samplers arrive as linear ones, CUBICSPLINE ones lose their tangents, and morph weights are
// clamped at 0. So for .gltf and .glb files the loader reads the animations' samplers from the
// JSON and buffers directly, and maps their target nodes onto Scene::nodes (which follow
// Assimp's node tree: the scene's roots depth first, under a "ROOT" node when there are several).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "scene/scene.h"

namespace myriad::scene::detail {

struct GltfFile {
  std::string_view bytes;  // the .gltf (JSON) or .glb
  bool binary = false;
  // A file the glTF refers to (a buffer's uri), relative to the model's folder; nullopt when it
  // cannot be read.
  std::function<std::optional<std::string>(const std::string& uri)> read;
};

// Replaces scene.animations with the file's own, when the file's node tree maps onto
// scene.nodes (same count, same names in the same order) and every sampler can be read; else
// leaves them as Assimp gave them. Returns a reason when the file's animation data is hostile or
// past a limit of scene/animation.h (non-finite or decreasing key times, non-finite values,
// counts that do not match, a key count past kMaxAnimationFloats, accessors outside their
// buffers), which refuses the model.
std::optional<std::string> readGltfAnimations(const GltfFile& file, Scene& scene);

}  // namespace myriad::scene::detail
