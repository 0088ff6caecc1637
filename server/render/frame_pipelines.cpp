// The frame's pipeline layout and the pipelines of the passes every technique shares
// (Pipelines, passes.h).
#include "render/passes.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <utility>
#include <vector>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/raster.h"
#include "markers.h"
#include "shared_types.h"

namespace myriad::render {

gpu::VertexLayout surfaceVertexLayout() {
  return {sizeof(scene::Vertex),
          {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
           {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
           {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)},
           {3, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(scene::Vertex, tangent)},
           {4, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(scene::Vertex, color)}}};
}

Pipelines::Pipelines(gpu::Context& context) : device(context.device) {
  const VkShaderStageFlags all =
      VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
  std::array<VkDescriptorSetLayoutBinding, 11> sceneBindings{{
      {MYRIAD_BINDING_FRAME, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_INSTANCES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_MATERIALS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHT_ORIGINS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_ENVIRONMENT, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_BRDF_LUT, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_SUN_SHADOW_MAP, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHT_SHADOW_ATLAS, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all, nullptr},
      {MYRIAD_BINDING_LIGHT_TEXELS, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, all, nullptr},
      {MYRIAD_BINDING_MATERIAL_TEXELS, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, all, nullptr},
  }};
  sceneSetLayout = gpu::createDescriptorSetLayout(device, sceneBindings);
  const VkShaderStageFlags readers = VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
  std::array<VkDescriptorSetLayoutBinding, 18> targetBindings{};
  for (uint32_t i = 0; i <= MYRIAD_BINDING_LIGHT_COUNT; ++i) {
    targetBindings[i] = {i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, readers, nullptr};
  }
  targetBindings[MYRIAD_BINDING_GBUFFER_EMISSIVE] = {MYRIAD_BINDING_GBUFFER_EMISSIVE,
                                                     VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                                     readers, nullptr};
  targetBindings[MYRIAD_BINDING_GBUFFER_LAYERS] = {MYRIAD_BINDING_GBUFFER_LAYERS,
                                                   VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                                   readers, nullptr};
  targetBindings[MYRIAD_BINDING_HDR_STORAGE] = {MYRIAD_BINDING_HDR_STORAGE,
                                                VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                                VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetBindings[MYRIAD_BINDING_LIGHT_COUNT_STORAGE] = {MYRIAD_BINDING_LIGHT_COUNT_STORAGE,
                                                        VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                                        VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  for (uint32_t storage : {MYRIAD_BINDING_MARKER_KEYS, MYRIAD_BINDING_OUTPUT, MYRIAD_BINDING_LDR_STORAGE}) {
    targetBindings[storage] = {storage, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                               VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  targetBindings[MYRIAD_BINDING_LDR] = {MYRIAD_BINDING_LDR, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                        1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetBindings[MYRIAD_BINDING_EDGE_PIXELS] = {MYRIAD_BINDING_EDGE_PIXELS,
                                                VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                                VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetBindings[MYRIAD_BINDING_YUV_PLANES] = {MYRIAD_BINDING_YUV_PLANES,
                                               VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                               VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetBindings[MYRIAD_BINDING_CLUSTER_MARKS] = {MYRIAD_BINDING_CLUSTER_MARKS,
                                                  VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                                  VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  targetSetLayout = gpu::createDescriptorSetLayout(device, targetBindings);
  std::array<VkDescriptorSetLayoutBinding, 6> cullingBindings{};
  for (uint32_t i = 0; i < cullingBindings.size(); ++i) {
    // Fragment too: the clustered technique marks blended surfaces' clusters from fragments, and
    // the forward pass reads the lists.
    cullingBindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, readers, nullptr};
  }
  cullingSetLayout = gpu::createDescriptorSetLayout(device, cullingBindings);
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_TEXTURE_SLOTS> materialBindings{};
  for (uint32_t i = 0; i < materialBindings.size(); ++i) {
    materialBindings[i] = {i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                           VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  }
  materialSetLayout = gpu::createDescriptorSetLayout(device, materialBindings);
  VkDescriptorSetLayout setLayouts[] = {sceneSetLayout, targetSetLayout, cullingSetLayout,
                                        materialSetLayout};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 4;
  layoutInfo.pSetLayouts = setLayouts;
  // The shadow pass's light view-projection (ShadowPush); no other pass uses push constants.
  const VkPushConstantRange shadowPush{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(gpu_types::ShadowPush)};
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &shadowPush;
  VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &layout));

  gpu::GraphicsPipelineDesc d;
  d.vertexShader = spirv::gbuffer_vert;
  d.fragmentShader = spirv::gbuffer_frag;
  d.vertexLayout = surfaceVertexLayout();
  d.colorFormats = {kNormalFormat,   kBaseColorFormat, kMaterialFormat,
                    kUvFormat,       kEmissiveFormat,  kLayersFormat};
  d.depthFormat = kDepthFormat;
  d.depthTest = d.depthWrite = true;
  d.depthCompare = VK_COMPARE_OP_LESS;
  d.dynamicCullMode = true;  // per material: glTF's doubleSided
  gbuffer = gpu::createGraphicsPipeline(device, layout, d);
  d.fragmentShader = spirv::gbuffer_alpha_test_frag;
  gbufferAlphaTest = gpu::createGraphicsPipeline(device, layout, d);
  d.fragmentShader = spirv::gbuffer_untextured_frag;
  gbufferUntextured = gpu::createGraphicsPipeline(device, layout, d);
  // Labels: the same vertex stage (the same positions, bit for bit, so EQUAL finds the surface
  // the G-buffer kept), one uint target, the G-buffer depth tested and kept.
  {
    gpu::GraphicsPipelineDesc l = d;
    l.fragmentShader = spirv::labels_frag;
    l.colorFormats = {kLabelFormat};
    l.depthWrite = false;
    l.depthCompare = VK_COMPARE_OP_EQUAL;
    labels = gpu::createGraphicsPipeline(device, layout, l);
  }

  // Alpha-blended surfaces: the G-buffer's vertex stage, one HDR target blended `over`, the
  // G-buffer depth tested and kept.
  d.fragmentShader = spirv::forward_frag;
  d.colorFormats = {kHdrFormat};
  d.depthWrite = false;
  d.blend = gpu::Blend::Alpha;
  forward = gpu::createGraphicsPipeline(device, layout, d);
  d.fragmentShader = spirv::forward_clustered_frag;
  forwardClustered = gpu::createGraphicsPipeline(device, layout, d);

  // Shadow maps: depth only, both faces (render/shadows.cpp).
  d = {};
  d.vertexShader = spirv::shadow_vert;
  d.vertexLayout = {sizeof(scene::Vertex),
                    {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
  d.depthFormat = kDepthFormat;
  d.depthTest = d.depthWrite = true;
  d.depthCompare = VK_COMPARE_OP_LESS;
  shadow = gpu::createGraphicsPipeline(device, layout, d);

  // The light-volumes view: the volumes technique's proxies, drawn onto the 8-bit output.
  d = lightVolumeDesc(context);
  d.fragmentShader = spirv::light_volume_overlay_frag;
  d.colorFormats = {kOutputFormat};
  lightVolumeOverlay = gpu::createGraphicsPipeline(device, layout, d);

  animateLights = gpu::createComputePipeline(device, layout, spirv::light_animate_comp);
  markerSplat = gpu::createComputePipeline(device, layout, spirv::marker_splat_comp);
  // CPU devices (final_cpu.comp, the same image): 16x16 groups, so fewer border pixels encoded
  // twice, and edge pixels listed without the group count's two workgroup barriers, which
  // llvmpipe pays for on every group; GPUs keep 8x8 and one global atomic per group.
  // (Only where the device runs 16x16 groups: Vulkan guarantees 128 invocations.)
  const bool cpuFinal = context.info.isCpu &&
                        context.info.maxComputeWorkGroupInvocations >=
                            MYRIAD_FINAL_CPU_GROUP * MYRIAD_FINAL_CPU_GROUP &&
                        context.info.maxComputeWorkGroupSizeX >= MYRIAD_FINAL_CPU_GROUP;
  final = gpu::createComputePipeline(device, layout, cpuFinal ? spirv::final_cpu_comp : spirv::final_comp);
  if (cpuFinal) {
    finalGroup = MYRIAD_FINAL_CPU_GROUP;
    cpuFinal_ = true;
    finalParts_[MYRIAD_FINAL_ANTIALIAS | MYRIAD_FINAL_MARKERS] = final;  // the default parts
    antialiasEdges = gpu::createComputePipeline(device, layout, spirv::antialias_edges_comp);
  }
  finalRaw = gpu::createComputePipeline(device, layout, spirv::final_raw_comp);
  views = gpu::createComputePipeline(device, layout, spirv::views_comp);
  viewsRaw = gpu::createComputePipeline(device, layout, spirv::views_raw_comp);
  antialias = gpu::createComputePipeline(device, layout, spirv::antialias_comp);
  yuv420 = gpu::createComputePipeline(device, layout, spirv::yuv420_comp);
}

VkPipeline Pipelines::finalFor(bool antialias, bool markers) const {
  if (!cpuFinal_) return final;
  const uint32_t parts = (antialias ? MYRIAD_FINAL_ANTIALIAS : 0u) | (markers ? MYRIAD_FINAL_MARKERS : 0u);
  VkPipeline& pipeline = finalParts_[parts];
  if (!pipeline) {
    const VkSpecializationMapEntry entry{MYRIAD_SPEC_FINAL_PARTS, 0, sizeof(uint32_t)};
    const VkSpecializationInfo spec{1, &entry, sizeof(parts), &parts};
    pipeline = gpu::createComputePipeline(device, layout, spirv::final_cpu_comp, &spec);
  }
  return pipeline;
}

VkPipeline Pipelines::viewsFor(Target target, bool raw) const {
  if (target != Target::Shadow) return raw ? viewsRaw : views;
  VkPipeline& pipeline = shadowViews_[raw ? 1 : 0];
  if (!pipeline) {
    const VkBool32 shadowView = VK_TRUE;
    const VkSpecializationMapEntry entry{MYRIAD_SPEC_SHADOW_VIEW, 0, sizeof(VkBool32)};
    const VkSpecializationInfo spec{1, &entry, sizeof(shadowView), &shadowView};
    pipeline = gpu::createComputePipeline(device, layout, raw ? spirv::views_raw_comp : spirv::views_comp,
                                          &spec);
  }
  return pipeline;
}

Pipelines::~Pipelines() {
  for (VkPipeline p : finalParts_) {
    if (p && p != final) vkDestroyPipeline(device, p, nullptr);
  }
  for (VkPipeline p : shadowViews_) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  for (VkPipeline p : {gbuffer, gbufferAlphaTest, gbufferUntextured, labels, forward, forwardClustered, shadow, lightVolumeOverlay, animateLights,
                      markerSplat, final, finalRaw, views, viewsRaw, antialias, antialiasEdges,
                      yuv420}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  if (layout) vkDestroyPipelineLayout(device, layout, nullptr);
  if (sceneSetLayout) vkDestroyDescriptorSetLayout(device, sceneSetLayout, nullptr);
  if (targetSetLayout) vkDestroyDescriptorSetLayout(device, targetSetLayout, nullptr);
  if (cullingSetLayout) vkDestroyDescriptorSetLayout(device, cullingSetLayout, nullptr);
  if (materialSetLayout) vkDestroyDescriptorSetLayout(device, materialSetLayout, nullptr);
}
}  // namespace myriad::render
