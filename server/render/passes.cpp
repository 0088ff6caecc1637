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

namespace {

using gpu::ImageTransition;

// G-buffer images are read by fragment shaders (sun, light volumes, forward) and by compute (the
// lighting of the tiled and clustered techniques, markers, the final and views passes).
ImageTransition colorWriteToSampled(const gpu::Image& image) {
  return {&image,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

// From whichever kind of write produced the image (attachment or storage) to sampling by compute
// (the final and views passes).
ImageTransition writtenToSampled(const gpu::Image& image, VkImageLayout layout) {
  if (layout == VK_IMAGE_LAYOUT_GENERAL) {
    return {&image, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
            VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
            VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
  }
  ImageTransition t = colorWriteToSampled(image);
  t.dstStage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  return t;
}

}  // namespace

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
  std::array<VkDescriptorSetLayoutBinding, 17> targetBindings{};
  for (uint32_t i = 0; i <= MYRIAD_BINDING_LIGHT_COUNT; ++i) {
    targetBindings[i] = {i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, readers, nullptr};
  }
  targetBindings[MYRIAD_BINDING_GBUFFER_EMISSIVE] = {MYRIAD_BINDING_GBUFFER_EMISSIVE,
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
  d.colorFormats = {kNormalFormat, kBaseColorFormat, kMaterialFormat, kUvFormat, kEmissiveFormat};
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

Pipelines::~Pipelines() {
  for (VkPipeline p : finalParts_) {
    if (p && p != final) vkDestroyPipeline(device, p, nullptr);
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

void recordGBufferPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                       const SceneBuffers& scene, uint32_t written, const MeshDetail& detail) {
  // Last frame's readers: the raster lighting (fragment) and compute lighting and views (compute).
  const VkPipelineStageFlags2 reader =
      VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  const ImageTransition before[] = {
      discardForColorWrite(t.normal, reader),
      discardForColorWrite(t.baseColor, reader),
      discardForColorWrite(t.material, reader),
      discardForColorWrite(t.uv, reader),
      discardForColorWrite(t.emissive, reader),
      {&t.depth, reader | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL},
  };
  gpu::barrier(cmd, before);

  std::array<VkRenderingAttachmentInfo, 5> colors = {
      colorAttachment(t.normal, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.baseColor, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.material, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.uv, VK_ATTACHMENT_LOAD_OP_CLEAR),
      colorAttachment(t.emissive, VK_ATTACHMENT_LOAD_OP_CLEAR)};
  for (auto& c : colors) c.clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};
  // Optional targets the frame does not read are left unbound: their writes are discarded (and
  // their contents undefined; FrameUniforms.written tells the shaders).
  if ((written & MYRIAD_GBUFFER_UV) == 0) colors[3].imageView = VK_NULL_HANDLE;
  if ((written & MYRIAD_GBUFFER_EMISSIVE) == 0) colors[4].imageView = VK_NULL_HANDLE;
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depth.imageView = t.depth.view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  beginRendering(cmd, t.extent, colors, &depth);
  bindGeometry(cmd, scene);
  // Opaque materials first, then alpha-tested ones (their own pipeline: a shader that may discard
  // writes depth only after it runs). Draws come grouped by material (SceneBuffers sorts them):
  // one texture set and one cull mode per group.
  // Opaque materials without textures draw with gbufferUntextured (gbuffer.glsl says why).
  InstancedDraws draws(cmd);
  for (const bool alphaTest : {false, true}) {
    VkPipeline pipelineBound = VK_NULL_HANDLE;
    uint32_t bound = UINT32_MAX;
    for (const DrawItem& draw : scene.draws) {
      if (scene.blend[draw.material]) continue;  // the forward pass draws it (recordBlendPass)
      if ((scene.alphaTest[draw.material] != 0) != alphaTest) continue;
      const VkPipeline pipeline = alphaTest                        ? p.gbufferAlphaTest
                                  : scene.textured[draw.material] ? p.gbuffer
                                                                  : p.gbufferUntextured;
      if (pipeline != pipelineBound) {
        draws.flush();
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        pipelineBound = pipeline;
      }
      if (draw.material != bound) {
        draws.flush();
        bound = draw.material;
        VkDescriptorSet set = scene.textures->set(bound);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout,
                                MYRIAD_SET_MATERIAL, 1, &set, 0, nullptr);
        vkCmdSetCullMode(cmd, scene.doubleSided[bound] ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
      }
      const MeshRange mesh = detail.range(scene, draw);
      if (mesh.indexCount == 0) continue;  // outside the view
      draws.add(mesh, draw.instance);
    }
    draws.flush();
  }
  vkCmdEndRendering(cmd);

  const ImageTransition after[] = {
      colorWriteToSampled(t.normal),
      colorWriteToSampled(t.baseColor),
      colorWriteToSampled(t.material),
      colorWriteToSampled(t.uv),
      colorWriteToSampled(t.emissive),
      {&t.depth, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
           VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
       VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL},
  };
  gpu::barrier(cmd, after);
}

bool hasBlendDraws(const SceneBuffers& scene) {
  return std::any_of(scene.draws.begin(), scene.draws.end(),
                     [&](const DrawItem& d) { return scene.blend[d.material] != 0; });
}

VkImageLayout recordBlendPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                              const SceneBuffers& scene, const glm::mat4& view,
                              VkImageLayout hdrLayout, bool clusterLists) {
  // Back to front: the farthest centre (most negative view-space z) first; ties keep scene order.
  std::vector<std::pair<float, const DrawItem*>> order;
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material]) order.emplace_back((view * glm::vec4(draw.centre, 1.0f)).z, &draw);
  }
  if (order.empty()) return hdrLayout;
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  const bool storage = hdrLayout == VK_IMAGE_LAYOUT_GENERAL;
  const ImageTransition before[] = {
      storage ? ImageTransition{&t.hdr, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                                VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT |
                                    VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}
              : colorWriteToBlend(t.hdr)};
  gpu::barrier(cmd, before);
  if (clusterLists) {
    // The lists were filled by compute (the clustered technique's assign step).
    gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  }
  VkRenderingAttachmentInfo color = colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, clusterLists ? p.forwardClustered : p.forward);
  bindGeometry(cmd, scene);
  uint32_t bound = UINT32_MAX;
  for (const auto& [z, draw] : order) {
    if (draw->material != bound) {
      bound = draw->material;
      VkDescriptorSet set = scene.textures->set(bound);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, MYRIAD_SET_MATERIAL,
                              1, &set, 0, nullptr);
      vkCmdSetCullMode(cmd, scene.doubleSided[bound] ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
    }
    vkCmdDrawIndexed(cmd, draw->mesh.indexCount, 1, draw->mesh.firstIndex, draw->mesh.vertexOffset,
                     draw->instance);
  }
  vkCmdEndRendering(cmd);
  return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
}

void recordMarkerPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                      const SceneBuffers& scene) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  constexpr VkAccessFlags2 kReadWrite =
      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  // Keys: the previous frame's final pass read them; clear to 0 (no marker).
  const ImageTransition clear[] = {{&t.markerKeys, kCompute, VK_ACCESS_2_NONE,
                                    VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                    VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL}};
  gpu::barrier(cmd, clear);
  const VkClearColorValue zero{};
  VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdClearColorImage(cmd, t.markerKeys.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &range);
  const ImageTransition splat[] = {{&t.markerKeys, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                                    VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite,
                                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, splat);
  // Depth is already readable by compute (recordGBufferPass); lights by every stage.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.markerSplat);
  if (scene.lightCount > 0) {
    vkCmdDispatch(cmd, gpu::groupCount(scene.lightCount, MYRIAD_LIGHTS_PER_GROUP), 1, 1);
  }
  // The final pass reads the keys (its resolve).
  const ImageTransition resolve[] = {
      {&t.markerKeys, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute,
       VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, resolve);
}

VkExtent2D finalPassGroups(const Pipelines& p, const FrameTargets& t, Target target) {
  const bool picture = target == Target::Final || target == Target::LightVolumes;
  const uint32_t group = picture && !t.raw ? p.finalGroup : MYRIAD_PIXEL_GROUP;
  return {gpu::groupCount(t.extent.width, group), gpu::groupCount(t.extent.height, group)};
}

void recordFinalPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t, Target target,
                     bool markers, bool antialias, VkImageLayout hdrLayout,
                     VkImageLayout lightCountLayout, uint32_t first, uint32_t count) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  const bool picture = target == Target::Final || target == Target::LightVolumes;
  const VkPipeline pipeline = picture ? (t.raw ? p.finalRaw : p.finalFor(antialias, markers))
                                      : (t.raw ? p.viewsRaw : p.views);
  const VkExtent2D groups = finalPassGroups(p, t, target);
  if (first > 0) {
    // A later range of a split frame's pass: the first range made the layouts and the edge list.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    gpu::dispatchGroupRange(cmd, groups.width, groups.height, first, count);
    return;
  }
  std::vector<ImageTransition> before = {
      writtenToSampled(t.hdr, hdrLayout),
      writtenToSampled(t.lightCount, lightCountLayout),
      // The previous frame's last use of the output was the readback copy.
      // (or, for a YCbCr frame, the conversion's loads).
      {&t.output, VK_PIPELINE_STAGE_2_COPY_BIT | kCompute, VK_ACCESS_2_NONE, kCompute,
       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
  };
  // The final shader binds the keys and (8-bit) the LDR target whether or not this frame uses
  // them, so they get their layout either way. Their previous contents are not needed: the keys
  // were last read by the previous final pass, the LDR target sampled by the previous
  // anti-aliasing pass.
  if (picture && !markers) {
    before.push_back({&t.markerKeys, kCompute, VK_ACCESS_2_NONE, kCompute,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_GENERAL});
  }
  if (picture && !t.raw) {
    before.push_back({&t.ldr, kCompute, VK_ACCESS_2_NONE, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  }
  gpu::barrier(cmd, before);
  if (picture && !t.raw) {
    // The edge list starts empty (the previous anti-aliasing pass read it, as its dispatch's
    // arguments and from the shader).
    gpu::bufferBarrier(cmd, t.edges,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const gpu_types::AntialiasEdges empty{{0, 1, 1, 0}, {0, 0, 0, 0}};
    vkCmdUpdateBuffer(cmd, t.edges.buffer, 0, sizeof(empty), &empty);
    gpu::bufferBarrier(cmd, t.edges, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  gpu::dispatchGroupRange(cmd, groups.width, groups.height, 0, count);
}

void recordAntialiasPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  // The output is already GENERAL (recordFinalPass); the final pass wrote the pixels off edges,
  // this pass writes the listed ones (disjoint, so no barrier on the output between them).
  const ImageTransition before[] = {{&t.ldr, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute,
                                     VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                     VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, before);
  if (p.antialiasEdges) {
    // CPU devices: the edge test, from the LDR target (final_pass.glsl's CPU main), which lists
    // the edge pixels and writes the others to the output.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.antialiasEdges);
    vkCmdDispatch(cmd, gpu::groupCount(t.extent.width, p.finalGroup),
                  gpu::groupCount(t.extent.height, p.finalGroup), 1);
  }
  gpu::bufferBarrier(cmd, t.edges, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     kCompute | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.antialias);
  vkCmdDispatchIndirect(cmd, t.edges.buffer, 0);
}

void recordLightVolumeOverlayPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                                  const SceneBuffers& scene) {
  // The final pass stored the dimmed picture; blending reads and writes it.
  const ImageTransition before[] = {
      {&t.output, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
       VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.output, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, {&color, 1}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.lightVolumeOverlay);
  drawLightProxies(cmd, scene);
  vkCmdEndRendering(cmd);
}

namespace {

// Copies the whole of `image` (last written at `writer` with `written`, in `layout`) into
// `readback`, rows top first, and makes it visible to the host.
void copyToReadback(VkCommandBuffer cmd, const gpu::Image& image, VkExtent2D extent,
                    VkPipelineStageFlags2 writer, VkAccessFlags2 written, VkImageLayout layout,
                    const gpu::Buffer& readback) {
  const ImageTransition before[] = {{&image, writer, written, VK_PIPELINE_STAGE_2_COPY_BIT,
                                     VK_ACCESS_2_TRANSFER_READ_BIT, layout,
                                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent.width, extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer,
                         1, &region);
  gpu::bufferBarrier(cmd, readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace

void recordLabelPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                     const SceneBuffers& scene, const MeshDetail& detail) {
  const ImageTransition before[] = {
      {&t.labels, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo color = colorAttachment(t.labels, VK_ATTACHMENT_LOAD_OP_CLEAR);
  color.clearValue.color.uint32[0] = color.clearValue.color.uint32[1] = 0;
  color.clearValue.color.uint32[2] = color.clearValue.color.uint32[3] = 0;
  const VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
  beginRendering(cmd, t.extent, std::span(&color, 1), &depth);
  bindGeometry(cmd, scene);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.labels);
  uint32_t cull = UINT32_MAX;
  InstancedDraws draws(cmd);
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material]) continue;  // not in the G-buffer: no label
    const uint32_t mode = scene.doubleSided[draw.material] ? 0u : 1u;
    if (mode != cull) {
      draws.flush();
      cull = mode;
      vkCmdSetCullMode(cmd, mode == 0 ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
    }
    const MeshRange mesh = detail.range(scene, draw);
    if (mesh.indexCount == 0) continue;  // outside the view
    draws.add(mesh, draw.instance);
  }
  draws.flush();
  vkCmdEndRendering(cmd);
}

void recordLabelReadback(VkCommandBuffer cmd, const FrameTargets& t, const gpu::Buffer& readback) {
  copyToReadback(cmd, t.labels, t.extent, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                 VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                 readback);
}

void recordReadback(VkCommandBuffer cmd, const FrameTargets& t, VkImageLayout outputLayout,
                    const gpu::Buffer& readback) {
  const bool storage = outputLayout == VK_IMAGE_LAYOUT_GENERAL;
  copyToReadback(cmd, t.output, t.extent,
                 storage ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT
                         : VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                 storage ? VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT
                         : VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                 outputLayout, readback);
}

void recordYuv420Readback(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                          const gpu::Buffer& readback) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  // The final (and anti-aliasing) pass stored the output; this pass loads it.
  const ImageTransition before[] = {{&t.output, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                     kCompute, VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                                     VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, before);
  const Yuv420Layout layout = yuv420Layout(t.extent.width, t.extent.height);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.yuv420);
  vkCmdDispatch(cmd, gpu::groupCount(layout.yStride / 8, MYRIAD_PIXEL_GROUP),
                gpu::groupCount(layout.rows / 2, MYRIAD_PIXEL_GROUP), 1);
  gpu::bufferBarrier(cmd, t.planes, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  const VkBufferCopy region{0, 0, layout.bytes()};
  vkCmdCopyBuffer(cmd, t.planes.buffer, readback.buffer, 1, &region);
  gpu::bufferBarrier(cmd, readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace myriad::render
