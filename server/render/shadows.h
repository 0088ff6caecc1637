// Shadow maps. The sun's is one orthographic depth map over the scene's bounds: it does not move
// with the camera (so it never swims), at the cost of texels sized to the whole scene rather than
// to the view (cascades fitted to the view would spend them better; not built yet).
// Local lights that ask for shadows (scene::PointLight::castsShadows) get tiles in one depth atlas,
// the most important first, up to settings.shadows.maxShadowedLights a frame (planLightShadows).
#pragma once

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

// The sun's map fitted to the scene: a square around the bounds' sphere, seen along the sun.
struct SunShadowFit {
  glm::mat4 viewProjection{1.0f};  // world -> the map's clip space (the shadow pass)
  glm::mat4 mapFromWorld{1.0f};    // world -> (u, v, depth) of the map (the lighting)
  float texelWorld = 0.0f;         // one texel's width in world units
};

// `direction` is the way the sunlight travels (non-zero); `size` the map's width in texels.
SunShadowFit fitSunShadow(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size);

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

  // Makes the sun's map `size` x `size` (kept while the size stays). Call before the frame's
  // descriptors are written: a new size is a new image.
  void ensureSun(uint32_t size);
  // The sun's map for set 0 (READ_ONLY_OPTIMAL, the comparison sampler). Valid after ensureSun
  // or ensureSunPlaceholder.
  VkDescriptorImageInfo sunDescriptor() const;
  // With the sun's shadows off the shaders never sample the map, but the descriptor must still
  // name an image in READ_ONLY_OPTIMAL: ensureSunPlaceholder makes a 1x1 one if there is none
  // (before the descriptors are written), recordSunUnused its first layout change.
  void ensureSunPlaceholder();
  void recordSunUnused(VkCommandBuffer cmd);

  // The "shadow" pass: every draw of `scene`, depth only, into the sun's map, which is left
  // readable by the lighting (fragment and compute shaders).
  void recordSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                 const glm::mat4& viewProjection);
  // Whether the map already holds what recordSun would draw: an earlier frame of this slot drew
  // this very scene (SceneBuffers::generation: geometry never changes in place) with this
  // `viewProjection` (the fit follows the scene's bounds, the sun's direction and the map size,
  // not the camera) into this image. Then the frame skips the pass: the map is unchanged and
  // still readable, and nothing has written it since.
  bool sunHolds(const SceneBuffers& scene, const glm::mat4& viewProjection) const;
  // The "shadow" pass made incremental: when the map holds an earlier generation of this scene
  // drawn with this `viewProjection`, and only a few instances moved since (SceneBuffers::
  // movedSince), clears and draws again only the texels under their old and new places (one
  // scissor rectangle around them, with only the casters reaching into it), which leaves the map
  // as recordSun would draw it. Returns false, recording nothing, when it cannot (then recordSun).
  bool repairSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                 const glm::mat4& viewProjection);

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
  glm::mat4 sunViewProjection_{1.0f};
  gpu::Arena atlasArena_;     // the atlas's own, so a new sun size keeps it (and the reverse)
  gpu::Image atlas_;
  bool atlasReadable_ = false;
  VkSampler sampler_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
