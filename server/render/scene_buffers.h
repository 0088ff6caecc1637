// One scene on the GPU: one vertex and one index buffer for every mesh (plus the light proxy
// sphere), and storage buffers for instances, materials and lights. Built from a scene::Scene in
// one upload; lights and materials are then edited in place, uploading only what changed.
// Each scene has its own small arenas, so destroying it frees its memory at once.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "render/skinning.h"
#include "render/textures.h"
#include "scene/scene.h"
#include "shared_types.h"

namespace myriad::render {

struct MeshRange {
  uint32_t firstIndex = 0;
  uint32_t indexCount = 0;
  int32_t vertexOffset = 0;
};

struct DrawItem {
  MeshRange mesh;
  uint32_t instance = 0;  // index into the instance buffer, passed as firstInstance
  uint32_t material = 0;  // the instance's material: draws are sorted by it
  glm::vec3 centre{0.0f};  // world-space centre of the mesh's bounds: alpha-blended draws sort by it
  uint32_t meshIndex = 0;  // scene::Instance::mesh: SceneBuffers::lods[meshIndex]
  float radius = 0.0f;     // world-space radius of the mesh's bounds around `centre`
  float unitScale = 1.0f;  // world units per mesh unit (the transform's largest axis scale)
};

struct SceneBuffers;

// A mesh's coarser versions on the GPU (scene::Mesh::lods): index ranges over its vertices, and
// their errors in mesh units, finest first.
struct MeshLods {
  std::vector<MeshRange> ranges;
  std::vector<float> errors;
};

// Which version of each mesh the G-buffer pass draws for a frame: the full meshes, or where the
// frame allows it (FrameSettings::geometryErrorPixels > 0) the coarsest version whose error,
// projected at the draw's nearest point to the eye, covers at most that many pixels.
// Also which draws the frame shows at all: a draw whose bounding sphere lies wholly outside the
// camera's frustum gets an empty range (indexCount 0; the passes skip it), so a scene of 100,000
// objects costs the G-buffer what is in view.
struct MeshDetail {
  float maxErrorPixels = 0.0f;  // 0: the full meshes
  glm::vec3 eye{0.0f};
  float pixelsAtUnitDistance = 0.0f;  // height / (2 tan(fovY / 2))
  float nearPlane = 0.0f;
  // The frustum's six planes (world space, inside where dot(plane, (p, 1)) >= 0); `cull` false
  // (a default MeshDetail): every draw is drawn.
  std::array<glm::vec4, 6> planes{};
  bool cull = false;

  static MeshDetail of(const FrameSettings& settings);
  MeshRange range(const SceneBuffers& scene, const DrawItem& draw) const;
};

// A light that asks for a shadow (scene::PointLight::castsShadows): its index in the light
// buffer and what was uploaded there (render/shadows.h plans the frame's maps from these).
struct ShadowCaster {
  uint32_t index = 0;
  gpu_types::GpuPointLight light{};
};

struct SceneBuffers {
  // Throws std::invalid_argument when an instance names a missing mesh or material, or a material
  // a missing image. `materialSetLayout`: the layout of set 3 (Pipelines::materialSetLayout).
  SceneBuffers(gpu::Context& context, gpu::CommandRecorder& recorder, const scene::Scene& scene,
               VkDescriptorSetLayout materialSetLayout);

  // See LightUpdate (render/frame.h). Validates before touching anything: on
  // std::invalid_argument the scene is unchanged.
  void updateLights(gpu::CommandRecorder& recorder, const LightUpdate& update);
  // Writes new transforms of instances in place (their draws' culling spheres follow) and takes
  // the update's bounds; renews `generation`, since what was drawn from the old placement (the
  // sun's shadow map) no longer holds. Throws std::invalid_argument (and changes nothing) for an
  // index past the instances or a transform that is not finite and invertible.
  void updateInstances(gpu::CommandRecorder& recorder, const InstanceUpdate& update);
  // Poses (render/skinning.h). Whether `pose` differs from the one last applied; applyPose
  // applies it: node transforms as updateInstances does, joint matrices and morph weights
  // uploaded for the next frame's pre-pass, the deformed draws' culling spheres and the bounds
  // grown to hold them. The caller waited for frames in flight. Throws std::invalid_argument
  // (and changes nothing) for a pose that does not fit the scene.
  bool poseDiffers(const ScenePose& pose) const;
  void applyPose(gpu::CommandRecorder& recorder, std::shared_ptr<const ScenePose> pose);
  // The same for a motion frame's previous pose (render/motion.h): the previous placements of
  // every instance (this frame's, with `previous`'s transforms over them) and, for deformed
  // instances, their previous positions (written by the next pre-pass).
  bool previousDiffers(const ScenePose& previous) const;
  void applyPrevious(gpu::CommandRecorder& recorder, std::shared_ptr<const ScenePose> previous);
  // Skinned and morphed instances (render/skinning.h): null for a scene with none (and no
  // motion frame's previous pose).
  std::unique_ptr<ScenePosing> posing;
  // Records that deformed draws moved (their old and new spheres, as `moves` holds them) and
  // renews `generation`.
  void geometryMoved(std::vector<glm::vec4> spheres);

  // Throws std::invalid_argument (and changes nothing) for an index past the materials.
  void updateMaterials(gpu::CommandRecorder& recorder, const std::vector<MaterialWrite>& writes);

  // GPU memory this scene holds.
  uint64_t bytes() const {
    return arena.bytesAllocated() + lightArena->bytesAllocated() + textures->bytes() +
           (posing && posing->motionArena ? posing->motionArena->bytesAllocated() : 0);
  }

  gpu::Context& context;
  // Unique among all the placements of geometry the process makes (from 1): what was drawn from
  // the scene's geometry (the sun's shadow map) may be kept while it stays. A new model is a new
  // SceneBuffers; moving instances in place (updateInstances) gives it a new generation too.
  uint64_t generation;
  // Where instances moved (updateInstances), latest last: per update, the generation it left and
  // the world-space bounding spheres (centre, radius) of each moved draw's old and new place. What
  // was drawn from an older generation (the sun's map) can then be repaired where they were and
  // are, instead of drawn again whole (ShadowMaps::repairSun). At most kMoveHistory updates.
  struct Moves {
    uint64_t from = 0;
    std::vector<glm::vec4> spheres;
  };
  static constexpr size_t kMoveHistory = 16;
  std::vector<Moves> moves;
  // The spheres moved since `earlier` (a generation this scene had), or nothing when the history
  // no longer reaches back to it or more than `limit` spheres moved since.
  std::optional<std::vector<glm::vec4>> movedSince(uint64_t earlier, size_t limit) const;
  gpu::Arena arena;                        // geometry, instances, materials
  std::unique_ptr<gpu::Arena> lightArena;  // the two light buffers; replaced when they grow
  gpu::Buffer vertices;
  gpu::Buffer indices;
  gpu::Buffer instances;
  gpu::Buffer materials;
  gpu::Buffer lights;        // where the lights are this frame (animation writes here)
  gpu::Buffer lightOrigins;  // where the scene put them
  // `lights` (RGBA32F) and `materials` (RGBA32UI) as texel buffers (MYRIAD_BINDING_*_TEXELS),
  // owned by the arena of the buffer they view.
  VkBufferView lightTexels = VK_NULL_HANDLE;
  VkBufferView materialTexels = VK_NULL_HANDLE;
  std::vector<DrawItem> draws;         // grouped by material
  uint32_t instanceCount = 0;
  std::vector<MeshLods> lods;          // per scene mesh (empty ranges: none)
  std::unique_ptr<MaterialTextures> textures;
  std::vector<uint8_t> doubleSided;   // per material: whether back faces are drawn
  // Per material: alphaMode BLEND, drawn by the forward pass (recordBlendPass), not into the
  // G-buffer. Follows material edits, like doubleSided.
  std::vector<uint8_t> blend;
  std::vector<uint8_t> alphaTest;     // per material: alphaMode MASK (the G-buffer's discarding pipeline)
  std::vector<uint8_t> emits;         // per material: whether its emission can be non-zero
  std::vector<uint8_t> layered;       // per material: whether it has a clear coat or a sheen
  std::vector<uint8_t> textured;      // per material: whether it has any texture slot
  bool anyEmission() const;
  // Whether a material has a clear coat or a sheen (the layers G-buffer target is written).
  bool anyLayers() const;
  MeshRange lightProxy;  // icosphere circumscribing the unit sphere (volumes, markers)
  uint32_t lightCount = 0;
  uint32_t lightCapacity = 0;  // lights the two light buffers hold
  uint32_t materialCount = 0;
  scene::Bounds bounds;
  bool lightsMoved = false;  // `lights` holds animated positions, not the origins
  // The lights asking for shadows, sorted by index; follows updateLights. One entry per asking
  // light (52 bytes: a million asking cost 52 MB of host memory, bounded by the light count).
  std::vector<ShadowCaster> shadowCasters;

  // The kinds of light the scene holds, as MYRIAD_FEATURE_SPOT_LIGHTS, _WINDOW_FALLOFF and
  // _INVERSE_SQUARE bits (render/shading_features.h); follows updateLights.
  uint32_t lightFeatures() const;

 private:
  scene::Bounds restBounds_;  // the scene's bounds as built (poseBounds grows them)
  scene::Bounds poseBounds() const;
  static gpu_types::GpuInstance gpuInstance(const glm::mat4& transform, uint32_t material,
                                            uint32_t object, uint32_t semantic);
  // Sets a draw's culling sphere and scale for its instance's `transform`.
  void place(DrawItem& draw, const glm::mat4& transform) const;
  void allocateLights(uint32_t capacity);
  // What updateInstances needs to place an instance's draw again: each instance's material and
  // mesh (the GPU instance's other members), its draw (UINT32_MAX: none, an empty mesh), and
  // each mesh's bounding sphere in mesh units.
  std::vector<uint32_t> instanceMaterial_;
  std::vector<uint32_t> instanceMesh_;
  std::vector<uint32_t> instanceObject_;
  std::vector<uint32_t> instanceSemantic_;
  std::vector<uint32_t> drawOfInstance_;
  std::vector<glm::vec3> meshCentres_;
  std::vector<float> meshRadii_;
  void updateShadowCasters(const LightUpdate& update);
  // lightFeatures' bookkeeping: each light's kind bits (one byte a light) and how many lights
  // have each kind.
  void setLightKinds(uint32_t count, const LightUpdate* update,
                     const std::vector<gpu_types::GpuPointLight>* all);
  std::vector<uint8_t> lightKinds_;
  uint32_t spotLights_ = 0;
  uint32_t windowLights_ = 0;
  uint32_t inverseSquareLights_ = 0;
};

// Scale that makes a mesh with vertices on the unit sphere contain the unit sphere: 1 / the
// smallest distance from the centre to any triangle's plane. A proxy that merely touched the
// sphere at its vertices would cut light off between them.
float circumscribeScale(const scene::Mesh& unitSphereMesh);

}  // namespace myriad::render
