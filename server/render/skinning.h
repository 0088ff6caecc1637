// Skinning and morphing on the GPU (glTF 2.0 skins and morph targets): a compute pre-pass
// (shaders/skinning.comp) deforms each posed instance's mesh into a region of its own at the end
// of the scene's vertex buffer, and that instance's draws read the region (DrawItem::mesh's
// vertexOffset), so the G-buffer (raster and compute), shadows, labels and the blend pass all see
// the posed mesh without knowing it. A scene with no skinned or morphed instance has no regions,
// no buffers and no pass.
//
// A pose (render::ScenePose) is applied when a frame carries one that differs from the last
// applied (SceneBuffers::poseDiffers / applyPose): node transforms go through the instance
// update path, joint matrices and morph weights are uploaded, and the next frame runs the pass
// ("skin" in its pass timings). The same pose gives the same bytes: nothing depends on history.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::render {

struct SceneBuffers;
struct MeshRange;

// What a scene's posed instances need on the GPU, and what was last applied to them. Made by
// SceneBuffers (planPosing) for a scene with skinned or morphed instances; made empty for a scene
// whose first motion frame carries a previous pose (only its previous placements, then).
struct ScenePosing {
  explicit ScenePosing(gpu::Context& context) : context(context) {}
  ~ScenePosing();
  ScenePosing(const ScenePosing&) = delete;
  ScenePosing& operator=(const ScenePosing&) = delete;

  struct Posed {
    uint32_t instance = 0;
    uint32_t mesh = 0;
    uint32_t firstRest = 0;     // the mesh's first vertex in the scene's vertex buffer
    uint32_t vertexCount = 0;
    uint32_t firstPosed = 0;    // its region's first vertex (the draw's vertexOffset)
    uint32_t firstInfluence = UINT32_MAX;  // UINT32_MAX: not skinned
    uint32_t jointCount = 0;
    uint32_t firstTarget = 0;   // into the targets table (one per morph target of the mesh)
    uint32_t targetCount = 0;
    uint32_t firstJointRow = 0;  // into the pose buffer (vec4 rows, three a joint)
    uint32_t firstWeight = 0;    // float index into the pose buffer
    uint32_t firstPrevious = 0;  // into the previous positions
    std::vector<uint32_t> usedJoints;  // joints some vertex weighs (bounds)
    glm::vec3 restCentre{0.0f};        // the rest vertices' bounding sphere (asset space)
    float restRadius = 0.0f;
    std::vector<float> targetReach;    // per morph target: its longest position displacement
  };
  gpu::Context& context;
  std::vector<Posed> posed;
  std::vector<uint32_t> posedOf;   // per instance: index into `posed`, or UINT32_MAX
  uint32_t poseVec4s = 0;          // the pose buffer's size in vec4s (joint rows, then weights)
  uint32_t previousVertices = 0;   // posed vertices in all
  uint32_t mostVertices = 0;       // of one posed instance (the dispatch's width)
  // Each posed instance's placement (instance transform), kept as the scene's edits change it.
  std::vector<glm::mat4> transforms;
  std::vector<glm::vec4> restPose;  // the pose buffer's content at rest (nodes, default weights)
  // The tables planPosing made, until uploadPosing copies them to the GPU.
  std::vector<glm::uvec4> hostInfluences;
  std::vector<float> hostMorphs;
  std::vector<glm::uvec4> hostTargets;

  // GPU (in the scene's arena).
  gpu::Buffer influences, morphs, targets, jobs, pose;
  bool dirty = true;  // the posed regions are to be written by the next frame's pre-pass
  std::shared_ptr<const ScenePose> lastPose;  // the pose applied (null: rest)

  // Motion (render/motion.h): made by the first motion frame that carries a previous pose.
  std::unique_ptr<gpu::Arena> motionArena;
  gpu::Buffer previousPose;         // as `pose`, at the previous time
  gpu::Buffer previousPositions;    // vec4 per posed vertex (at least one)
  gpu::Buffer vertexRecords;        // uvec4 per instance (MYRIAD_MOTION_BINDING_VERTICES)
  gpu::Buffer previousInstances;    // GpuInstance per instance, placed at the previous time
  bool previousDirty = true;        // previousPositions are to be written by the pre-pass
  std::shared_ptr<const ScenePose> lastPrevious;
  uint64_t previousGeneration = 0;  // the scene generation previousInstances were built from

  // The pre-pass's descriptor sets (current pose, previous pose), made on first use.
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet currentSet = VK_NULL_HANDLE;
  VkDescriptorSet previousSet = VK_NULL_HANDLE;

  // The pose buffer's content for `pose` (rest for what it leaves out). Throws
  // std::invalid_argument for a pose naming an instance that is not skinned or morphed, joints
  // or weights of the wrong count, or values that are not finite.
  std::vector<glm::vec4> poseContent(const ScenePose& pose) const;
  // A sphere (xyz centre, w radius) holding posed instance `p`'s vertices in asset space, for
  // pose content `content`.
  glm::vec4 posedSphere(const Posed& p, const std::vector<glm::vec4>& content) const;
};

// Plans `scene`'s posed instances: appends a copy of each one's mesh vertices to `vertices` (its
// region, starting on a 16-vertex boundary) and returns the plan, or null when nothing in the
// scene is skinned or morphed. `ranges`: each mesh's place in `vertices`.
std::unique_ptr<ScenePosing> planPosing(gpu::Context& context, const scene::Scene& scene,
                                        const std::vector<MeshRange>& ranges,
                                        std::vector<scene::Vertex>& vertices);
// Creates and fills the posing's buffers from `scene` in `arena` (after the vertex buffer).
void uploadPosing(ScenePosing& posing, gpu::Arena& arena, gpu::CommandRecorder& recorder);

// Host data written into device buffers in one submission that waits (the scene's edits).
struct BufferWrite {
  const gpu::Buffer* destination = nullptr;
  VkDeviceSize offset = 0;
  const void* data = nullptr;
  VkDeviceSize size = 0;
};
struct BufferCopy {
  const gpu::Buffer* source = nullptr;
  const gpu::Buffer* destination = nullptr;
  VkDeviceSize size = 0;
};
void writeBuffers(gpu::Context& context, gpu::CommandRecorder& recorder,
                  const std::vector<BufferCopy>& copies, const std::vector<BufferWrite>& writes);

// Whether every element of `m` is finite: a pose's joints and an edit's transforms must be.
bool finiteTransform(const glm::mat4& m);

// The pre-pass's pipeline (one per renderer).
class SkinningPass {
 public:
  explicit SkinningPass(gpu::Context& context);
  ~SkinningPass();
  SkinningPass(const SkinningPass&) = delete;
  SkinningPass& operator=(const SkinningPass&) = delete;

  // Whether a frame of `scene` runs the pass: its posed regions (and, with `previous`, its
  // previous positions) are out of date.
  static bool needed(const SceneBuffers& scene, bool previous);
  // Records the pass where needed ("skin"): the posed vertices, then (with `previous`) the
  // previous positions; leaves them readable by vertex input and by compute (the compute
  // G-buffer, the motion pass's vertex stage).
  void record(VkCommandBuffer cmd, SceneBuffers& scene, bool previous, gpu::PassTimer& timer);

 private:
  void ensureSets(SceneBuffers& scene);
  gpu::Context& context_;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
