// Shadow maps. The sun's is one orthographic depth map over the scene's bounds: it does not move
// with the camera (so it never swims), at the cost of texels sized to the whole scene rather than
// to the view (cascades fitted to the view would spend them better; not built yet).
#pragma once

#include <cstdint>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "scene/scene.h"

namespace myriad::render {

// The sun's map fitted to the scene: a square around the bounds' sphere, seen along the sun.
struct SunShadowFit {
  glm::mat4 viewProjection{1.0f};  // world -> the map's clip space (the shadow pass)
  glm::mat4 mapFromWorld{1.0f};    // world -> (u, v, depth) of the map (the lighting)
  float texelWorld = 0.0f;         // one texel's width in world units
};

// `direction` is the way the sunlight travels (non-zero); `size` the map's width in texels.
SunShadowFit fitSunShadow(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size);

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

  // Frees the maps (Renderer::releaseFrameMemory); the next frame makes them again.
  void release();
  uint64_t gpuMemoryBytes() const;

 private:
  gpu::Context& context_;
  gpu::Arena arena_;
  gpu::Image sun_;
  bool sunReadable_ = false;  // the map has been put into READ_ONLY_OPTIMAL at least once
  VkSampler sampler_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
