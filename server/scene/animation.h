// glTF 2.0 animation on the CPU: a clip's channels sampled at a time (step, linear with
// quaternion slerp, cubic spline), node transforms to world matrices, and per instance what the
// GPU needs to draw it posed: its transform (node animation) and, for skinned or morphed meshes,
// joint matrices and morph weights. Also a CPU posing of a mesh's vertices (morph, then skin, as
// glTF and three.js order them), the reference the GPU pre-pass is compared with.
//
// The limits a model's animation data must respect live here too: the loader child refuses a
// file past them (ModelLoadError naming the limit) and the parent re-checks them on the wire.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "scene/scene.h"

namespace myriad::scene {

// ---- Limits on one model's animation data (what a file past them is refused for).
// Nodes kept (the flattening walk's own visit cap).
inline constexpr size_t kMaxNodes = size_t(1) << 20;
inline constexpr size_t kMaxSkins = 4096;
// Joints of one skin: glTF viewers commonly allow 256+; 1024 is a GPU matrix palette of 64 KiB.
inline constexpr size_t kMaxJointsPerSkin = 1024;
inline constexpr size_t kMaxAnimations = 1024;
// Channels over all animations of a model.
inline constexpr size_t kMaxAnimationChannels = size_t(1) << 16;
// Key floats (times plus values) over all channels: 16 Mi floats, 64 MiB. A "1 GB sampler"
// claim is refused by this, or earlier by the loader child's memory limit.
inline constexpr size_t kMaxAnimationFloats = size_t(1) << 24;
// Morph targets of one mesh, and displacement vectors (3 floats) over all targets of a model.
inline constexpr size_t kMaxMorphTargets = 64;
inline constexpr size_t kMaxMorphVectors = size_t(1) << 24;
// Longest clip: keys past a day are a broken file, not an animation.
inline constexpr float kMaxAnimationSeconds = 86400.0f;

// How many floats one key of `path` holds (per morph target for weights: `targets`).
size_t keyWidth(AnimationPath path, size_t targets);

// Why a model's animation data cannot be used (a sentence naming what and which limit), or
// nothing: every index in range (nodes' parents earlier, skins' joints, channels' nodes, mesh
// joints below their skins' sizes), every float finite, times strictly increasing, value counts
// matching key counts, the limits above. The loader and the wire decoder both call it.
std::optional<std::string> checkAnimationData(const Scene& scene);

// A node's local matrix: translation * rotation * scale.
glm::mat4 localMatrix(const Node& node);

// The time within a clip that plays `seconds` after it started: looped (wrapped into
// [0, duration)) or held (clamped to [0, duration]). A clip of duration 0 is always at 0.
double clipTime(const Animation& clip, double seconds, bool loop);

// Samples one channel at clip time `t` into `out` (keyWidth floats): before the first key its
// first value, after the last its last; rotations are unit quaternions (x, y, z, w).
void sampleChannel(const AnimationChannel& channel, double t, std::span<float> out);

// Unit quaternion between a and b along the shorter arc (glTF's "linear" for rotations).
glm::quat slerpShortest(const glm::quat& a, const glm::quat& b, float u);

// The scene's nodes posed by one clip at one clip time (or at rest: no clip).
struct PosedNodes {
  std::vector<glm::mat4> world;  // per node, in the model's space
  // Per node: 1 when a channel of the clip moves it or an ancestor (its instances then move).
  std::vector<uint8_t> moved;
  // Per node, its meshes' morph weights from the clip's weights channel (empty: not animated).
  std::vector<std::vector<float>> weights;
};
PosedNodes poseNodes(const Scene& scene, const Animation* clip, double clipSeconds);

// One instance of a model posed: what changes from how the model was loaded.
struct PosedInstance {
  uint32_t instance = 0;               // index into Scene::instances
  std::optional<glm::mat4> transform;  // node-animated: its new transform (model space)
  std::vector<glm::mat4> joints;       // skinned: world(joint) * inverseBind, per joint
  std::vector<float> morphWeights;     // morphed: one per target of its mesh
};

// Every instance of `scene` that the pose changes or that needs a pose to be drawn (skinned or
// morphed): node-animated instances get a transform, skinned ones joint matrices, morphed ones
// weights (the clip's, else the mesh's defaults). `clip` < 0: the rest pose.
std::vector<PosedInstance> poseInstances(const Scene& scene, int clip, double seconds, bool loop);

// Whether anything in `scene` needs posing at all (skins, morph targets or animations).
bool animated(const Scene& scene);

// The clip `name` names: an index ("0", "1"...) or an animation's name. -1 when none matches.
int findClip(const Scene& scene, std::string_view name);

// The world bounds of every instance posed by `clip` at `seconds` (clip < 0: the rest pose, the
// node tree as loaded and the meshes' default morph weights): what the model covers when drawn
// posed, where Scene::bounds() gives skinned meshes in their bind space.
Bounds posedBounds(const Scene& scene, int clip, double seconds, bool loop);

// The mesh's vertices posed on the CPU (glTF 2.0 order: morph targets add weight * delta to
// position, normal and tangent, then the skin moves them by sum(weight_i * joints[joint_i])).
// Normals and tangents go through the same matrices' upper 3x3 and are normalised (three.js's
// convention, not the inverse transpose). Empty `joints`: not skinned; empty `morphWeights`:
// the mesh's defaults. The result is in the instance's space (then moved by its transform).
std::vector<Vertex> poseVertices(const Mesh& mesh, std::span<const glm::mat4> joints,
                                 std::span<const float> morphWeights);

}  // namespace myriad::scene
