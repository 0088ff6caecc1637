// The scene edits the renderer takes (Renderer::updateLights, updateInstances,
// updateMaterials) and the poses a frame carries: part of the contract between the service and
// the renderer (render/frame.h includes it). Plain data; no Vulkan, no HTTP.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "scene/scene.h"

namespace myriad::render {

// A scene the renderer holds on the GPU (Renderer::createScene). Never 0; never reused.
using SceneId = uint32_t;

// Light edits (Renderer::updateLights). After the update the scene has `count` lights, and
// light[w.index] = w.light for each write; every index in [old count, count) must be written, and
// no index may be >= count. Only the written elements are uploaded, so an edit of one light costs
// one light, whatever the scene holds; the GPU buffers grow by doubling when `count` outgrows them.
// Removing light i of n: count = n - 1 and write the last light into i (if i < n - 1).
struct LightWrite {
  uint32_t index = 0;
  scene::PointLight light;
};

struct LightUpdate {
  uint32_t count = 0;
  std::vector<LightWrite> writes;
};

// New world transforms for some instances of a scene (Renderer::updateInstances): an object moved.
// The instances keep their meshes and materials; `bounds` is the whole scene's bounds after the
// move (scene::Scene::bounds() of the moved scene: the caller keeps them per instance).
struct InstanceWrite {
  uint32_t index = 0;  // into scene::Scene::instances
  glm::mat4 transform{1.0f};
};
struct InstanceUpdate {
  std::vector<InstanceWrite> writes;
  scene::Bounds bounds;
};

// A skinned or morphed instance posed at one time (scene/animation.h evaluates it): what the GPU
// pre-pass deforms its mesh's vertices by before the G-buffer, shadow and pick passes read them.
struct InstancePose {
  uint32_t instance = 0;  // index into scene::Scene::instances
  // Skinning matrices, one per joint of the instance's skin: the asset's space from the mesh's
  // bind space (world_asset(joint) * inverseBind). Empty: not skinned. The posed vertex is then
  // moved by the instance's transform as any other.
  std::vector<glm::mat4> joints;
  // One weight per morph target of its mesh (empty: the mesh's default weights).
  std::vector<float> morphWeights;
};

// A whole scene posed at `time`: node-animated instances' transforms and skinned or morphed
// instances' poses. A frame that carries one (FrameSettings::pose) is drawn in exactly that pose,
// so the same time gives the same bytes.
struct ScenePose {
  double time = 0.0;
  std::vector<InstanceWrite> transforms;
  std::vector<InstancePose> poses;
};

// The time between a motion frame and its previous time, in seconds (one frame at 30 Hz).
inline constexpr double kMotionInterval = 1.0 / 30.0;

// One material's new factors (Renderer::updateMaterials); index < the scene's material count.
struct MaterialWrite {
  uint32_t index = 0;
  scene::Material material;
};

}  // namespace myriad::render
