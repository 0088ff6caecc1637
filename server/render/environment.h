// The environment light on the GPU (image-based lighting): per scene, a source radiance pyramid
// and the lighting maps prefiltered from it (SH9 irradiance + a split-sum specular chain), and,
// shared, the BRDF integration table computed once at start-up. The maths is
// shaders/environment.glsl; this file allocates, decides when to rebuild, and records the passes.
//
// Sizes (shaders/shared_types.h): source 256x128 plus its 2x2-box pyramid to 8x4 (43,680 texels),
// 6 specular levels of 128x64 (perceptual roughness 0, 0.2, ... 1; 64 GGX samples a texel), SH9
// summed over the 64x32 level, the BRDF table 32x32 (256 samples a texel). All vec4 float32 in
// storage buffers: 1.5 MiB per scene with the environment on (plus 512 KiB staging for a .hdr);
// nothing for a scene that never turns it on.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "scene/environment_map.h"

namespace myriad::render {

// One scene's environment maps. Rebuilt (recorded into the frame's command buffer, timed as the
// "environment" pass) only when what they come from changes: the mode, the image, or for the sky
// the sun's direction or colour. Intensity and rotation are applied when the maps are read, so
// changing them costs nothing.
struct SceneEnvironment {
  explicit SceneEnvironment(gpu::Context& context);

  // The .hdr the `hdr` mode shows (already at the source size). Staged at once; copied to the
  // GPU by the next rebuild.
  void setImage(std::shared_ptr<const scene::EnvironmentImage> image);
  bool hasImage() const { return image != nullptr; }
  uint64_t bytes() const { return arena.bytesAllocated() + (stagingArena ? stagingArena->bytesAllocated() : 0); }

  gpu::Context& context;
  gpu::Arena arena;
  gpu::Buffer source;    // the radiance pyramid (MYRIAD_ENV_SOURCE_TEXELS vec4)
  gpu::Buffer lighting;  // SH9 header + the specular levels, what shading reads
  std::unique_ptr<gpu::Arena> stagingArena;
  gpu::Buffer staging;   // the .hdr's level 0, host-visible
  std::shared_ptr<const scene::EnvironmentImage> image;
  uint64_t imageVersion = 0;

  // What the maps were last built from.
  struct Inputs {
    EnvironmentMode mode = EnvironmentMode::None;
    glm::vec3 toSun{0.0f};
    glm::vec3 sunColor{0.0f};
    uint64_t imageVersion = 0;
    bool operator==(const Inputs&) const = default;
  };
  std::optional<Inputs> built;
  uint64_t rebuilds = 0;  // how many times the maps were built (tests check it stays put)
};

// The passes that build environments, and the BRDF table they and every lighting shader share.
class EnvironmentPasses {
 public:
  // Computes the BRDF table (one submission on `recorder`).
  EnvironmentPasses(gpu::Context& context, gpu::CommandRecorder& recorder);
  ~EnvironmentPasses();
  EnvironmentPasses(const EnvironmentPasses&) = delete;
  EnvironmentPasses& operator=(const EnvironmentPasses&) = delete;

  const gpu::Buffer& brdfLut() const { return brdfLut_; }
  uint64_t gpuMemoryBytes() const { return arena_.bytesAllocated(); }

  // What `settings` needs the maps built from (the sun's direction and colour count for the sky
  // only). Throws std::invalid_argument for `hdr` without an image.
  static SceneEnvironment::Inputs inputsFor(const FrameSettings& settings, const SceneEnvironment& env);
  // Records the rebuild of `env` from `inputs`; the caller checked they changed. Leaves the maps
  // readable by fragment and compute shaders.
  void record(VkCommandBuffer cmd, SceneEnvironment& env, const SceneEnvironment::Inputs& inputs);

 private:
  void writeSet(const gpu::Buffer& source, const gpu::Buffer& lighting);

  gpu::Context& context_;
  gpu::Arena arena_;
  gpu::Buffer brdfLut_;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  VkPipeline sky_ = VK_NULL_HANDLE;
  VkPipeline downsample_ = VK_NULL_HANDLE;
  VkPipeline irradiance_ = VK_NULL_HANDLE;
  VkPipeline prefilter_ = VK_NULL_HANDLE;
  VkPipeline lut_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
