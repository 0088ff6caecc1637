// A frame's preparation: the slot's targets fitted to the frame, the uniforms written, and
// descriptor sets 0 (scene) and 1 (targets) pointed at this frame's scene and targets.
#include <cmath>
#include <cstring>
#include <optional>

#include "gpu/vk_check.h"
#include "render/cluster_grid.h"
#include "render/extra_targets.h"
#include "render/renderer_state.h"
#include "render/shading_features.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// The light-count view's hottest colour when the request leaves it to us.
constexpr uint32_t kDefaultHeatMapMax = 64;

}  // namespace

// `environment` is the scene's lighting maps, or any storage buffer when the environment is off
// (the shaders then never read it).
void Renderer::State::writeSceneSet(FrameSlot& slot, const SceneBuffers& scene,
                                    const gpu::Buffer& environment) {
  const VkDescriptorImageInfo sunShadowMap = slot.shadows->sunDescriptor();
  const VkDescriptorImageInfo lightShadowAtlas = slot.shadows->atlasDescriptor();
  VkDescriptorBufferInfo buffers[7] = {
      {slot.uniforms.buffer, 0, sizeof(FrameUniforms)},
      {scene.lights.buffer, 0, VK_WHOLE_SIZE},
      {scene.instances.buffer, 0, VK_WHOLE_SIZE},
      {scene.materials.buffer, 0, VK_WHOLE_SIZE},
      {scene.lightOrigins.buffer, 0, VK_WHOLE_SIZE},
      {environment.buffer, 0, VK_WHOLE_SIZE},
      {environmentPasses->brdfLut().buffer, 0, VK_WHOLE_SIZE},
  };
  VkWriteDescriptorSet writes[11];
  for (uint32_t i = 0; i < 7; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = slot.sceneSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        i == MYRIAD_BINDING_FRAME ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  writes[7] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  writes[7].dstSet = slot.sceneSet;
  writes[7].dstBinding = MYRIAD_BINDING_SUN_SHADOW_MAP;
  writes[7].descriptorCount = 1;
  writes[7].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[7].pImageInfo = &sunShadowMap;
  writes[8] = writes[7];
  writes[8].dstBinding = MYRIAD_BINDING_LIGHT_SHADOW_ATLAS;
  writes[8].pImageInfo = &lightShadowAtlas;
  writes[9] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  writes[9].dstSet = slot.sceneSet;
  writes[9].dstBinding = MYRIAD_BINDING_LIGHT_TEXELS;
  writes[9].descriptorCount = 1;
  writes[9].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
  writes[9].pTexelBufferView = &scene.lightTexels;
  writes[10] = writes[9];
  writes[10].dstBinding = MYRIAD_BINDING_MATERIAL_TEXELS;
  writes[10].pTexelBufferView = &scene.materialTexels;
  vkUpdateDescriptorSets(context.device, 11, writes, 0, nullptr);
}

void Renderer::State::writeTargetSet(FrameSlot& slot) {
  const std::unique_ptr<FrameTargets>& targets = slot.targets;
  // Bindings 0-6 and 9 are sampled (READ_ONLY_OPTIMAL); 7-8 are the same HDR and light-count
  // images as storage images (GENERAL), written by compute lighting; 10 the markers' keys, 11 the
  // output and 13 the LDR target are storage (GENERAL); 12 is the LDR target sampled with a
  // linear filter.
  constexpr uint32_t kBindings = 14;
  const gpu::Image* images[kBindings] = {
      &targets->depth,    &targets->normal,     &targets->baseColor, &targets->material,
      &targets->uv,       &targets->hdr,        &targets->lightCount, &targets->hdr,
      &targets->lightCount, &targets->emissive, &targets->markerKeys, &targets->output,
      &targets->ldr,      &targets->ldr};
  VkDescriptorImageInfo infos[kBindings];
  VkWriteDescriptorSet writes[kBindings];
  for (uint32_t i = 0; i < kBindings; ++i) {
    bool storage = i == MYRIAD_BINDING_HDR_STORAGE || i == MYRIAD_BINDING_LIGHT_COUNT_STORAGE ||
                   i == MYRIAD_BINDING_MARKER_KEYS || i == MYRIAD_BINDING_OUTPUT ||
                   i == MYRIAD_BINDING_LDR_STORAGE;
    VkSampler filter = i == MYRIAD_BINDING_LDR ? linearSampler : sampler;
    infos[i] = {storage ? VK_NULL_HANDLE : filter, images[i]->view,
                storage ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = slot.targetSet;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        storage ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &infos[i];
  }
  // 14: the edge pixels the final pass lists for anti-aliasing (a storage buffer).
  const VkDescriptorBufferInfo edges{targets->edges.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet edgeWrite{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  edgeWrite.dstSet = slot.targetSet;
  edgeWrite.dstBinding = MYRIAD_BINDING_EDGE_PIXELS;
  edgeWrite.descriptorCount = 1;
  edgeWrite.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  edgeWrite.pBufferInfo = &edges;
  // 15: the YCbCr planes (yuv420.comp).
  const VkDescriptorBufferInfo planes{targets->planes.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet planeWrite = edgeWrite;
  planeWrite.dstBinding = MYRIAD_BINDING_YUV_PLANES;
  planeWrite.pBufferInfo = &planes;
  // 16: the clusters the compute G-buffer marked (clustered).
  const VkDescriptorBufferInfo marks{targets->clusterMarks.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet markWrite = edgeWrite;
  markWrite.dstBinding = MYRIAD_BINDING_CLUSTER_MARKS;
  markWrite.pBufferInfo = &marks;
  // 17: the clear coat and sheen target (sampled, READ_ONLY_OPTIMAL like the G-buffer's).
  const VkDescriptorImageInfo layers{sampler, targets->layers.view,
                                     VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet layersWrite = writes[MYRIAD_BINDING_GBUFFER_EMISSIVE];
  layersWrite.dstBinding = MYRIAD_BINDING_GBUFFER_LAYERS;
  layersWrite.pImageInfo = &layers;
  vkUpdateDescriptorSets(context.device, kBindings, writes, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &layersWrite, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &edgeWrite, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &planeWrite, 0, nullptr);
  vkUpdateDescriptorSets(context.device, 1, &markWrite, 0, nullptr);
}

void Renderer::State::writeRawTargetSet(FrameSlot& slot) {
  std::vector<VkCopyDescriptorSet> copies;
  for (uint32_t binding = 0; binding <= MYRIAD_BINDING_GBUFFER_LAYERS; ++binding) {
    if (binding == MYRIAD_BINDING_OUTPUT) continue;
    VkCopyDescriptorSet copy{VK_STRUCTURE_TYPE_COPY_DESCRIPTOR_SET};
    copy.srcSet = slot.targetSet;
    copy.srcBinding = binding;
    copy.dstSet = slot.rawTargetSet;
    copy.dstBinding = binding;
    copy.descriptorCount = 1;
    copies.push_back(copy);
  }
  const VkDescriptorImageInfo output{VK_NULL_HANDLE, slot.targets->extraOutput.view,
                                     VK_IMAGE_LAYOUT_GENERAL};
  VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = slot.rawTargetSet;
  write.dstBinding = MYRIAD_BINDING_OUTPUT;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  write.pImageInfo = &output;
  vkUpdateDescriptorSets(context.device, 1, &write, uint32_t(copies.size()), copies.data());
}

// Targets follow the output size and are rebuilt only when it changes (every frame is waited
// for, so nothing is in flight here).
bool Renderer::State::ensureTargets(FrameSlot& slot, VkExtent2D extent, bool raw) {
  std::unique_ptr<FrameTargets>& targets = slot.targets;
  if (!targets || !targetsFit(*targets, extent, raw)) {
    targets.reset();
    targets = std::make_unique<FrameTargets>(context, extent, raw, clusterGrid(extent, tuning),
                                             computeWritableTargets());
    writeTargetSet(slot);
    return true;
  }
  return false;
}

void Renderer::State::writeUniforms(FrameSlot& slot, const FrameSettings& s,
                                    const SceneBuffers& scene,
                                    const LightingTechnique& technique,
                                    const SunShadowFit* sunShadow,
                                    const LightShadowPlan& lightShadows) {
  float aspect = float(s.width) / float(s.height);
  glm::mat4 view = scene::viewMatrix(s.camera);
  glm::mat4 projection = scene::projectionMatrix(s.camera, aspect);
  // TAA's sub-pixel jitter (FrameSettings::jitter): clip x and y move by 2 * jitter / size of w,
  // so every projected point moves by `jitter` pixels (y down in Vulkan's clip space).
  projection[2][0] -= 2.0f * s.jitter.x / float(s.width);
  projection[2][1] -= 2.0f * s.jitter.y / float(s.height);
  const scene::Bounds& bounds = scene.bounds;

  FrameUniforms u{};
  u.view = view;
  u.projection = projection;
  u.viewProjection = projection * view;
  u.inverseViewProjection = glm::inverse(u.viewProjection);
  u.cameraPosition = glm::vec4(s.camera.eye, 1.0f);
  u.sunDirection = glm::vec4(-glm::normalize(s.sun.direction), s.sun.intensity);
  u.sunColor = glm::vec4(s.sun.color, 0.0f);
  for (size_t i = 0; i < s.extraSuns.size() && i < MYRIAD_MAX_EXTRA_SUNS; ++i) {
    u.extraSunDirection[i] = glm::vec4(-glm::normalize(s.extraSuns[i].direction), s.extraSuns[i].intensity);
    u.extraSunColor[i] = glm::vec4(s.extraSuns[i].color, 0.0f);
  }
  u.ambient = glm::vec4(s.ambient, 0.0f);
  u.background = glm::vec4(s.background, 0.0f);
  u.viewport = glm::vec4(s.width, s.height, 1.0f / s.width, 1.0f / s.height);
  // w is unused (markers are sized in pixels: shaders/markers.glsl).
  u.camera = glm::vec4(s.exposure, s.camera.nearPlane, s.camera.farPlane, 0.0f);
  u.boundsMin = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.min, 0.0f);
  u.boundsMax = glm::vec4(bounds.empty() ? glm::vec3(1.0f) : bounds.max, 0.0f);
  u.flags = glm::uvec4(static_cast<uint32_t>(s.target), scene.lightCount, s.raw ? 1 : 0, 0);
  u.written = glm::uvec4(gbufferWrites(s, scene), tuning.clusterTile, 0, 0);
  // The cluster grid: the clustered technique's, and the clusters view's whatever the technique.
  const ClusterGrid g = clusterGrid({s.width, s.height}, tuning);
  u.grid = glm::uvec4(g.x, g.y, g.slices, static_cast<uint32_t>(s.technique));
  float slicesPerLog = float(g.slices) / std::log(s.camera.farPlane / s.camera.nearPlane);
  u.slicing = glm::vec4(slicesPerLog, std::log(s.camera.nearPlane) * slicesPerLog,
                        float(s.heatMapMax > 0 ? s.heatMapMax : kDefaultHeatMapMax), float(s.time));
  // The sky ignores the rotation: its orientation is the sun's.
  const float rotation =
      s.environment.mode == EnvironmentMode::Hdr ? s.environment.rotation : 0.0f;
  u.environment = glm::vec4(float(static_cast<uint32_t>(s.environment.mode)),
                            s.environment.intensity, s.environment.background ? 1.0f : 0.0f, 0.0f);
  u.environmentRotation = glm::vec4(std::cos(rotation), std::sin(rotation), 0.0f, 0.0f);
  u.post = glm::uvec4(static_cast<uint32_t>(s.antialiased() ? s.antialias : Antialias::None),
                      s.markers ? 1 : 0, 0, 0);
  if (sunShadow) {
    // Per cascade, offset: a texel along the normal (more at grazing angles, frame.glsl); bias: a
    // texel of depth, scaled by the slope there; and where the cascade ends.
    const glm::uvec2 grid = sunAtlasGrid(sunShadow->cascades);
    u.sunShadow = glm::vec4(float(sunShadow->cascades), float(sunShadow->tileSize), float(grid.x),
                            float(grid.y));
    for (uint32_t c = 0; c < sunShadow->cascades; ++c) {
      u.sunShadowMatrix[c] = sunShadow->mapFromWorld[c];
      // w: the cascade is in use (frame.glsl reads this, not sunShadow.x, in its loops).
      u.sunCascade[c] = glm::vec4(sunShadow->texelWorld[c], sunShadow->depthTexel[c],
                                  sunShadow->splitFar[c], 1.0f);
    }
  }
  if (!lightShadows.empty()) {
    u.lightShadows = glm::uvec4(uint32_t(lightShadows.lights.size()), lightShadows.tileSize,
                                lightShadows.atlas.width, lightShadows.atlas.height);
    for (size_t i = 0; i < lightShadows.lights.size(); ++i) {
      u.shadowedLightIndex[i / 4][int(i % 4)] = lightShadows.lights[i];
      u.lightShadow[i] = lightShadows.shadows[i];
    }
  }
  u.fog = glm::vec4(s.fog.color, s.fog.density);
  technique.writeUniforms(u);
  stochastic.writeUniforms(u, s, scene);
  slot.shadingFeatures = shadingFeatures(u, scene);
  std::memcpy(slot.uniforms.mapped, &u, sizeof(u));
}

// Fits the slot's targets and the technique's buffers to the frame; writes its uniforms and set 0.
bool Renderer::State::prepareFrame(FrameSlot& slot, SceneBuffers& scene,
                                   SceneEnvironment* environment, const FrameSettings& settings,
                                   LightingTechnique& technique) {
  VkExtent2D extent{settings.width, settings.height};
  applyPoses(scene, settings);  // before anything reads the scene's bounds or draws
  const bool madeTargets = ensureTargets(slot, extent, settings.raw);
  if (settings.drawsLabels()) slot.targets->ensureLabels();
  if (const ExtraRegions extras = extraRegionsOf(settings); extras.count > 0) {
    slot.targets->ensureExtras(extras.count);
    if (!settings.raw) writeRawTargetSet(slot);
  }
  technique.prepare(extent, scene.lightCount);
  // The sun's shadow map: fitted to this scene and sun, rendered this frame when on.
  const std::optional<SunShadowFit> sunShadow = sunShadowFor(scene, settings);
  if (sunShadow) {
    slot.shadows->ensureSun(*sunShadow);
  } else {
    slot.shadows->ensureSunPlaceholder();
  }
  // The local lights' maps: which lights get one this frame, their tiles in the atlas.
  slot.lightShadows = planLightShadows(scene.shadowCasters, settings);
  if (slot.lightShadows.empty()) {
    slot.shadows->ensureAtlasPlaceholder();
  } else {
    slot.shadows->ensureAtlas(slot.lightShadows.atlas);
  }
  writeUniforms(slot, settings, scene, technique, sunShadow ? &*sunShadow : nullptr,
                slot.lightShadows);
  writeSceneSet(slot, scene, environment ? environment->lighting : environmentPasses->brdfLut());
  return madeTargets;
}

void Renderer::State::applyPoses(SceneBuffers& scene, const FrameSettings& settings) {
  if (settings.pose && scene.poseDiffers(*settings.pose)) {
    quiesce();
    scene.applyPose(recorder, settings.pose);
  }
  if (settings.target == Target::Motion && settings.previousPose &&
      scene.previousDiffers(*settings.previousPose)) {
    quiesce();
    scene.applyPrevious(recorder, settings.previousPose);
  }
}

}  // namespace myriad::render
