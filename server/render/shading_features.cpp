#include "render/shading_features.h"

#include "gpu/pipelines.h"
#include "shared_types.h"

namespace myriad::render {

uint32_t shadingFeatures(const gpu_types::FrameUniforms& u, const SceneBuffers& scene) {
  uint32_t features = scene.lightFeatures();
  if (u.environment.x != float(MYRIAD_ENV_NONE)) features |= MYRIAD_FEATURE_ENVIRONMENT;
  if (u.sunShadow.x != 0.0f) features |= MYRIAD_FEATURE_SUN_SHADOW;
  for (int i = 0; i < MYRIAD_MAX_EXTRA_SUNS; ++i) {
    if (u.extraSunDirection[i].w > 0.0f) features |= MYRIAD_FEATURE_EXTRA_SUNS;
  }
  if ((u.written.x & MYRIAD_GBUFFER_EMISSIVE) != 0u) features |= MYRIAD_FEATURE_EMISSIVE;
  if ((u.written.x & MYRIAD_GBUFFER_LAYERS) != 0u) features |= MYRIAD_FEATURE_LAYERS;
  if (u.lightShadows.x != 0u) features |= MYRIAD_FEATURE_LOCAL_SHADOWS;
  return features;
}

FeaturePipelines::FeaturePipelines(VkDevice device, VkPipelineLayout layout,
                                   std::span<const uint32_t> shader)
    : device_(device), layout_(layout), shader_(shader) {}

FeaturePipelines::FeaturePipelines(VkDevice device, VkPipelineLayout layout,
                                   std::span<const uint32_t> shader, uint32_t variant)
    : device_(device), layout_(layout), shader_(shader), hasVariant_(true), variant_(variant) {}

FeaturePipelines::~FeaturePipelines() {
  for (const auto& [features, pipeline] : pipelines_) vkDestroyPipeline(device_, pipeline, nullptr);
}

VkPipeline FeaturePipelines::get(uint32_t features) {
  features &= MYRIAD_FEATURES_ALL;
  if (auto it = pipelines_.find(features); it != pipelines_.end()) return it->second;
  const VkSpecializationMapEntry entries[] = {{MYRIAD_SPEC_SHADING_FEATURES, 0, sizeof(uint32_t)},
                                              {MYRIAD_SPEC_SHADE_VARIANT, 4, sizeof(uint32_t)}};
  const uint32_t values[] = {features, variant_};
  const VkSpecializationInfo spec{hasVariant_ ? 2u : 1u, entries, sizeof(values), values};
  VkPipeline pipeline = gpu::createComputePipeline(device_, layout_, shader_, &spec);
  pipelines_.emplace(features, pipeline);
  return pipeline;
}

}  // namespace myriad::render
