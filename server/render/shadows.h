// Shadow maps. The sun's are cascades (Dimitrov 2007; Engel 2006): the view's depth, from its
// near plane to its far plane clamped to the scene's bounds, is split at the practical scheme's
// distances (Zhang et al. 2006: a blend, kCascadeLambda, of logarithmic and uniform splits), and
// each part of the view gets its own orthographic map, fitted to the bounding SPHERE of that frustum
// slice (the same size whatever the camera's rotation) and snapped to whole texels in the light's
// space, so a moving camera moves the maps by whole texels and static shadow edges do not shimmer.
// Each map's depth range holds the whole scene along the sun, so casters outside the slice still
// cast. The maps are tiles of one depth atlas (sunAtlasGrid); the shaders pick the cascade by view
// depth (frame.glsl sunShadowCascade). One cascade (settings.shadows.cascades 1) is one map over the
// scene's bounds instead, which never moves with the camera, its texels sized to the whole scene.
// The maps are drawn again only when the fit changed (a camera move with cascades, the scene's
// bounds, the sun) or the scene did (repaired under moved objects: ShadowMaps::repairSun).
// Local lights that ask for shadows (scene::PointLight::castsShadows) get tiles in one depth atlas,
// the most important first, up to settings.shadows.maxShadowedLights a frame (planLightShadows).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "scene/scene.h"
#include "shared_types.h"

namespace myriad::render {

// The blend of logarithmic (1) and uniform (0) splits of the view's depth between cascades.
inline constexpr float kCascadeLambda = 0.75f;

// The sun's maps for a frame: `cascades` square tiles of `tileSize` texels in one atlas.
struct SunShadowFit {
  uint32_t cascades = 1;
  uint32_t tileSize = 0;  // texels across one cascade's map
  // Per cascade (the first `cascades` hold values):
  std::array<glm::mat4, kMaxSunCascades> viewProjection{};  // world -> its clip space (the shadow pass)
  std::array<glm::mat4, kMaxSunCascades> mapFromWorld{};    // world -> (u, v, depth) of its tile
  std::array<float, kMaxSunCascades> texelWorld{};  // one texel's width in world units
  std::array<float, kMaxSunCascades> depthTexel{};  // one texel of world depth, in map depth
  std::array<float, kMaxSunCascades> splitFar{};    // where it ends: view depth (the last: FLT_MAX)
  // Whether the maps are the same (what ShadowMaps compares to keep or repair them).
  bool sameMaps(const SunShadowFit& other) const;
  VkExtent2D atlas() const;  // the atlas's size in texels
};

// The atlas's columns and rows of tiles for `cascades` maps: 1x1, 2x1, 2x2 (3 leaves one empty).
glm::uvec2 sunAtlasGrid(uint32_t cascades);

// One map fitted to the scene: a square around the bounds' sphere, seen along the sun.
// `direction` is the way the sunlight travels (non-zero); `size` the map's width in texels.
SunShadowFit fitSunShadow(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size);

// `cascades` (1..kMaxSunCascades; 1: fitSunShadow) maps fitted to `camera`'s view at `aspect`
// (width / height), each `size` texels across: split, fitted and snapped as the top of this file
// says. `snap` false leaves the maps where the spheres put them (for the shimmer test only).
SunShadowFit fitSunCascades(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size,
                            uint32_t cascades, const scene::Camera& camera, float aspect,
                            bool snap = true);

// Which lights get a shadow map this frame, and where: one tile for a spot light up to
// MYRIAD_SPOT_SHADOW_MAX_ANGLE, six (a cube) for a point light or a wider spot.
struct LightShadowPlan {
  std::vector<uint32_t> lights;                      // light indices, most important first
  std::vector<gpu_types::GpuLightShadow> shadows;    // per light, as the shaders read them
  std::vector<glm::mat4> tileViewProjection;         // per atlas tile: world -> its clip space
  uint32_t requested = 0;  // casters whose light reaches into the view (the others need no map)
  uint32_t dropped = 0;    // of those, the ones past the limit: shaded unshadowed
  uint32_t tileSize = 0;   // texels across a tile
  VkExtent2D atlas{0, 0};  // texels
  bool empty() const { return lights.empty(); }
};

// The tile size for a sun map size: a quarter of it, within MYRIAD_SHADOW_TILE_MIN..MAX.
uint32_t lightShadowTileSize(uint32_t mapSize);

// Where light `index` is at `time` when lights animate: light_orbit.glsl's orbit, on the CPU.
glm::vec3 animatedLightPosition(uint32_t index, const gpu_types::GpuPointLight& light, double time);

// Chooses up to `settings.shadows.maxShadowedLights` of `casters` (sorted by index) whose light
// reaches into the camera's view, by importance (luminance of the radiance times the share of the
// view the light's sphere spans, ties to the lower index), and lays their tiles out. O(casters).
LightShadowPlan planLightShadows(const std::vector<ShadowCaster>& casters,
                                 const FrameSettings& settings);

class ShadowMaps {
 public:
  explicit ShadowMaps(gpu::Context& context);
  ~ShadowMaps();
  ShadowMaps(const ShadowMaps&) = delete;
  ShadowMaps& operator=(const ShadowMaps&) = delete;

  // Makes the sun's atlas for `fit` (fit.atlas(); kept while the size stays). Call before the
  // frame's descriptors are written: a new size is a new image.
  void ensureSun(const SunShadowFit& fit);
  // The sun's atlas for set 0 (READ_ONLY_OPTIMAL, the comparison sampler). Valid after ensureSun
  // or ensureSunPlaceholder.
  VkDescriptorImageInfo sunDescriptor() const;
  // With the sun's shadows off the shaders never sample the map, but the descriptor must still
  // name an image in READ_ONLY_OPTIMAL: ensureSunPlaceholder makes a 1x1 one if there is none
  // (before the descriptors are written), recordSunUnused its first layout change.
  void ensureSunPlaceholder();
  void recordSunUnused(VkCommandBuffer cmd);

  // The "shadow" pass: every draw of `scene` that reaches into a cascade's square, depth only,
  // into the cascade's tile, which is left readable by the lighting (fragment and compute).
  void recordSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                 const SunShadowFit& fit);
  // Whether the atlas already holds what recordSun would draw: an earlier frame of this slot drew
  // this very scene (SceneBuffers::generation: geometry never changes in place) with these maps
  // (SunShadowFit::sameMaps: one cascade follows the scene's bounds, the sun's direction and the
  // map size; more follow the camera too) into this image. Then the frame skips the pass: the
  // atlas is unchanged and still readable, and nothing has written it since.
  bool sunHolds(const SceneBuffers& scene, const SunShadowFit& fit) const;
  // The "shadow" pass made incremental: when the atlas holds an earlier generation of this scene
  // drawn with these maps, and only a few instances moved since (SceneBuffers::movedSince),
  // clears and draws again, in each cascade, only the texels under their old and new places (one
  // scissor rectangle a cascade around them, with only the casters reaching into it), which
  // leaves the atlas as recordSun would draw it. Returns false, recording nothing, when it
  // cannot (then recordSun).
  bool repairSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                 const SunShadowFit& fit);
  // The "shadow" pass after a camera move: cascades follow the camera by whole texels
  // (fitSunCascades), so when the atlas holds this very scene drawn with maps of the same splits,
  // each cascade's new map is its old one shifted by whole texels. Copies what both hold into its
  // new place (through a tile-sized scratch image) and clears and draws only the strips the move
  // uncovered, with only the casters reaching into them. Returns false, recording nothing, when
  // it cannot (another scene generation, other splits or sun, one cascade, or moves that uncover
  // more than kMaxScrollShare of the maps: then recordSun).
  bool scrollSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                 const SunShadowFit& fit);

  // The local lights' atlas: ensureAtlas before the descriptors are written (a new size is a new
  // image), or ensureAtlasPlaceholder (1x1) when no light has a map this frame; recordLights draws
  // the plan's tiles (the "light-shadows" pass), recordAtlasUnused puts a new placeholder into
  // READ_ONLY_OPTIMAL.
  void ensureAtlas(VkExtent2D extent);
  void ensureAtlasPlaceholder();
  VkDescriptorImageInfo atlasDescriptor() const;
  void recordLights(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                    const LightShadowPlan& plan);
  void recordAtlasUnused(VkCommandBuffer cmd);

  // Frees the maps (Renderer::releaseFrameMemory); the next frame makes them again.
  void release();
  uint64_t gpuMemoryBytes() const;

 private:
  gpu::Context& context_;
  gpu::Arena arena_;
  gpu::Image sun_;
  bool sunReadable_ = false;  // the map has been put into READ_ONLY_OPTIMAL at least once
  uint64_t sunScene_ = 0;    // what the map holds (sunHolds): the scene's generation, 0 nothing
  SunShadowFit sunFit_;      // and the maps it was drawn with
  gpu::Arena scrollArena_;   // scrollSun's scratch tile, made on its first scroll
  gpu::Image scrollScratch_;
  gpu::Arena atlasArena_;     // the atlas's own, so a new sun size keeps it (and the reverse)
  gpu::Image atlas_;
  bool atlasReadable_ = false;
  VkSampler sampler_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
