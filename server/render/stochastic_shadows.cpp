#include "render/stochastic_shadows.h"

#include <algorithm>
#include <cstring>

#include "embedded_shaders.h"
#include "gpu/vk_check.h"
#include "shared_types.h"

namespace myriad::render {

StochasticShadows::StochasticShadows(gpu::Context& context, const Pipelines& pipelines,
                                     const Tuning& tuning)
    : context_(context), pipelines_(pipelines), tuning_(tuning) {}

void StochasticShadows::create() {
  if (bvh_) return;
  bvh_ = std::make_unique<Bvh>(context_);
  // Sets 0-2 and the push constant range as the frame's layout (passes.cpp), so the frame's
  // scene and target sets and the technique's culling set stay bound; set 3 the trace set.
  const VkDescriptorSetLayout sets[] = {pipelines_.sceneSetLayout, pipelines_.targetSetLayout,
                                        pipelines_.cullingSetLayout, bvh_->traceSetLayout()};
  static_assert(MYRIAD_SET_MATERIAL == 3);
  const VkPushConstantRange shadowPush{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(gpu_types::ShadowPush)};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 4;
  info.pSetLayouts = sets;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &shadowPush;
  VK_CHECK(vkCreatePipelineLayout(context_.device, &info, nullptr, &layout_));
  shade_ = std::make_unique<FeaturePipelines>(context_.device, layout_, spirv::shadow_rays_ris_comp);
}

StochasticShadows::~StochasticShadows() {
  shade_.reset();
  bvh_.reset();
  if (layout_) vkDestroyPipelineLayout(context_.device, layout_, nullptr);
}

bool StochasticShadows::wanted(const FrameSettings& settings) {
  return tracesLocalShadows(settings);
}

void StochasticShadows::writeUniforms(gpu_types::FrameUniforms& u, const FrameSettings& settings,
                                      const SceneBuffers& scene) const {
  u.stochastic = glm::uvec4(0u);
  if (!wanted(settings)) return;
  // The shadow ray leaves the surface this far along its normal: the C++ reference's offset
  // (1e-4 of the scene's size), well above the depth buffer's error in the reconstructed position.
  const float size = scene.bounds.empty() ? 1.0f : glm::length(scene.bounds.max - scene.bounds.min);
  const float offset = 1e-4f * std::max(1.0f, size);
  uint32_t offsetBits = 0;
  std::memcpy(&offsetBits, &offset, sizeof(offsetBits));
  // The seed: a different sequence per sample index (the shader hashes it further).
  // The sun's shadow, when it casts one, is traced too: one more ray, exact, and no map.
  const bool sun = settings.shadows.sun && settings.sun.intensity > 0.0f;
  u.stochastic = glm::uvec4(settings.sampleIndex * 0x9E3779B9u + 0x7F4A7C15u,
                            tuning_.stochasticCandidates,
                            MYRIAD_STOCHASTIC_ON | (sun ? MYRIAD_STOCHASTIC_TRACE_SUN : 0u), offsetBits);
}

void StochasticShadows::recordBvh(VkCommandBuffer cmd, const SceneBuffers& scene,
                                  gpu::PassTimer& timer) {
  create();
  bvh_->record(cmd, scene, tuning_.bvhUpdate, timer);
}

void StochasticShadows::bindShade(VkCommandBuffer cmd, uint32_t features) const {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, shade_->get(features));
  VkDescriptorSet trace = bvh_->traceSet();
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 3, 1, &trace, 0, nullptr);
}

}  // namespace myriad::render
