// Which of the shading's optional parts a frame may need (MYRIAD_FEATURE_* of shaders/
// shared_types.h), and compute pipelines specialised to exactly those (frame.glsl's
// kShadingFeatures). llvmpipe executes both sides of every branch, so on the CPU path a pixel
// paid for the environment light, the sun's 3x3 shadow taps, three extra suns, the spot cone and
// both falloffs whether or not the frame had them; specialised, the code a frame cannot use is
// compiled out. The image does not change: a feature's bit is set whenever the frame's uniforms or
// lights could use it, and the shaders still test the uniforms where the bit is set.
#pragma once

#include <cstdint>
#include <map>
#include <span>

#include <vulkan/vulkan.h>

#include "render/gpu_types.h"
#include "render/scene_buffers.h"

namespace myriad::render {

// The features the frame with uniforms `u` of `scene` may use.
uint32_t shadingFeatures(const gpu_types::FrameUniforms& u, const SceneBuffers& scene);

// One compute shader's pipelines, one per feature set a frame asked for (created then, and kept:
// at most MYRIAD_FEATURES_ALL + 1 of them).
class FeaturePipelines {
 public:
  FeaturePipelines(VkDevice device, VkPipelineLayout layout, std::span<const uint32_t> shader);
  // The same with MYRIAD_SPEC_SHADE_VARIANT set to `variant` as well (the clustered subgroup pass).
  FeaturePipelines(VkDevice device, VkPipelineLayout layout, std::span<const uint32_t> shader,
                   uint32_t variant);
  ~FeaturePipelines();
  FeaturePipelines(const FeaturePipelines&) = delete;
  FeaturePipelines& operator=(const FeaturePipelines&) = delete;

  // The pipeline specialised for `features`; creates it on first use (may throw
  // gpu::VulkanError).
  VkPipeline get(uint32_t features);

 private:
  VkDevice device_;
  VkPipelineLayout layout_;
  std::span<const uint32_t> shader_;
  bool hasVariant_ = false;
  uint32_t variant_ = 0;
  std::map<uint32_t, VkPipeline> pipelines_;
};

}  // namespace myriad::render
