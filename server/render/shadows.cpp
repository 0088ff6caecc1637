#include "render/shadows.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/frame_targets.h"
#include "render/light_packing.h"
#include "render/raster.h"
#include "render/shadow_recording.h"
#include "scene/camera.h"
#include "shared_types.h"

namespace myriad::render {

using namespace shadow_recording;

namespace {

// A map is a few MiB (2048^2 x 4 B = 16 MiB): blocks the size of what they hold.
constexpr VkDeviceSize kShadowBlockSize = 1ull << 20;

// The cube's faces as frame.glsl reads them (cubeFaceForward, cubeFaceUp): +X -X +Y -Y +Z -Z.
constexpr std::array<glm::vec3, 6> kFaceForward = {glm::vec3(1, 0, 0),  glm::vec3(-1, 0, 0),
                                                   glm::vec3(0, 1, 0),  glm::vec3(0, -1, 0),
                                                   glm::vec3(0, 0, 1),  glm::vec3(0, 0, -1)};
constexpr std::array<glm::vec3, 6> kFaceUp = {glm::vec3(0, 1, 0), glm::vec3(0, 1, 0),
                                              glm::vec3(0, 0, 1), glm::vec3(0, 0, 1),
                                              glm::vec3(0, 1, 0), glm::vec3(0, 1, 0)};

// A spot's map reaches this far past its outer cone, so the normal offset and the PCF taps at the
// cone's edge stay inside the tile.
constexpr float kSpotMargin = 0.0872664626f;  // 5 degrees

// light_orbit.glsl's hash01 (PCG-style, Jarzynski & Olano 2020), bit for bit.
float hash01(uint32_t v) {
  const uint32_t state = v * 747796405u + 2891336453u;
  const uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return float((word >> 22u) ^ word) / 4294967296.0f;
}

float luminance(glm::vec3 c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

}  // namespace

// What the sun's and the local lights' maps share when they record (render/shadow_recording.h).
namespace shadow_recording {

void beginShadowRendering(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                          const gpu::Image& map, bool keep, bool scrolled) {
  const gpu::ImageTransition before[] = {
      {&map, scrolled ? VK_PIPELINE_STAGE_2_COPY_BIT : kShadowReaders,
       scrolled ? VK_ACCESS_2_TRANSFER_WRITE_BIT : VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       scrolled ? VK_IMAGE_LAYOUT_GENERAL
                : keep ? VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
       VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depth.imageView = map.view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = keep ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  beginRendering(cmd, map.extent, {}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.shadow);
  bindGeometry(cmd, scene);
}

// Both faces: a single-sided wall still blocks the light; no fragment shader, so alpha-masked
// cut-outs cast as solid.
void drawCasters(VkCommandBuffer cmd, const SceneBuffers& scene) {
  InstancedDraws draws(cmd);
  for (const DrawItem& draw : scene.draws) draws.add(draw.mesh, draw.instance);
}

void endShadowRendering(VkCommandBuffer cmd, const gpu::Image& map) {
  vkCmdEndRendering(cmd);
  const gpu::ImageTransition after[] = {
      {&map, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kShadowReaders,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
       VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, after);
}

}  // namespace shadow_recording

uint32_t lightShadowTileSize(uint32_t mapSize) {
  return std::clamp<uint32_t>(mapSize / 4, MYRIAD_SHADOW_TILE_MIN, MYRIAD_SHADOW_TILE_MAX);
}

glm::vec3 animatedLightPosition(uint32_t index, const gpu_types::GpuPointLight& light, double time) {
  const float t = float(time);
  const float radius = light.positionRadius.w;
  const float speed = 0.4f + 0.8f * hash01(index * 3u);
  const float phase = 6.2831853f * hash01(index * 3u + 1u);
  const float reach = radius * (0.5f + 0.5f * hash01(index * 3u + 2u));
  const glm::vec3 offset = reach * glm::vec3(std::sin(speed * t + phase),
                                             0.25f * std::sin(1.7f * speed * t + phase),
                                             std::cos(0.8f * speed * t + phase));
  return glm::vec3(light.positionRadius) + offset;
}

LightShadowPlan planLightShadows(const std::vector<ShadowCaster>& casters,
                                 const FrameSettings& settings) {
  LightShadowPlan plan;
  if (casters.empty()) return plan;
  // Only `maps` draws maps (and `stochastic` where it falls back to them: tracesLocalShadows).
  if (settings.shadows.local == LocalShadows::None || tracesLocalShadows(settings)) return plan;
  const uint32_t limit = std::min(settings.shadows.maxShadowedLights, uint32_t(MYRIAD_MAX_SHADOWED_LIGHTS));
  const glm::mat4 viewProjection =
      scene::projectionMatrix(settings.camera, float(settings.width) / float(settings.height)) *
      scene::viewMatrix(settings.camera);
  // The view's planes (Gribb & Hartmann), inside where dot(plane, (p, 1)) >= 0; depth 0..1.
  std::array<glm::vec4, 6> planes;
  const glm::mat4 m = glm::transpose(viewProjection);  // rows of the matrix
  planes[0] = m[3] + m[0];
  planes[1] = m[3] - m[0];
  planes[2] = m[3] + m[1];
  planes[3] = m[3] - m[1];
  planes[4] = m[2];
  planes[5] = m[3] - m[2];
  for (glm::vec4& p : planes) p /= glm::length(glm::vec3(p));

  struct Candidate {
    float importance;
    uint32_t caster;
    glm::vec3 position;
  };
  std::vector<Candidate> candidates;
  for (uint32_t i = 0; i < casters.size(); ++i) {
    const gpu_types::GpuPointLight& light = casters[i].light;
    const float radius = light.positionRadius.w;
    const float bright = luminance(glm::vec3(light.radianceFalloff));
    if (!(radius > 0.0f) || !(bright > 0.0f)) continue;  // lights nothing: needs no map
    const glm::vec3 position = settings.animate
                                   ? animatedLightPosition(casters[i].index, light, settings.time)
                                   : glm::vec3(light.positionRadius);
    bool inView = true;
    for (const glm::vec4& p : planes) inView = inView && glm::dot(glm::vec3(p), position) + p.w >= -radius;
    if (!inView) continue;
    const float distance = glm::length(position - settings.camera.eye);
    const float coverage = radius * radius / std::max(distance * distance, radius * radius);
    candidates.push_back({bright * coverage, i, position});
  }
  plan.requested = static_cast<uint32_t>(candidates.size());
  const uint32_t chosen = std::min<uint32_t>(limit, plan.requested);
  plan.dropped = plan.requested - chosen;
  std::partial_sort(candidates.begin(), candidates.begin() + chosen, candidates.end(),
                    [&](const Candidate& a, const Candidate& b) {
                      if (a.importance != b.importance) return a.importance > b.importance;
                      return casters[a.caster].index < casters[b.caster].index;
                    });
  if (chosen == 0) return plan;

  plan.tileSize = lightShadowTileSize(settings.shadows.mapSize);
  const float tile = float(plan.tileSize);
  for (uint32_t c = 0; c < chosen; ++c) {
    const ShadowCaster& caster = casters[candidates[c].caster];
    const gpu_types::GpuPointLight& light = caster.light;
    const glm::vec3 position = candidates[c].position;
    const float far = light.positionRadius.w;
    const float near = std::max(far * 1e-3f, 1e-5f);
    // cone.z is cos(outer); a point light's is below -1.
    const bool spot = light.cone.z >= std::cos(MYRIAD_SPOT_SHADOW_MAX_ANGLE);
    gpu_types::GpuLightShadow shadow{};
    shadow.positionNear = glm::vec4(position, near);
    shadow.tiles = glm::uvec4(uint32_t(plan.tileViewProjection.size()),
                              spot ? MYRIAD_LIGHT_SHADOW_SPOT : MYRIAD_LIGHT_SHADOW_CUBE, 0, 0);
    if (spot) {
      const float half = std::acos(std::clamp(light.cone.z, -1.0f, 1.0f)) + kSpotMargin;
      const glm::vec3 forward = spotDirectionOf(light);
      const glm::vec3 up = std::abs(forward.y) > 0.99f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
      const glm::mat4 vp = glm::perspectiveRH_ZO(2.0f * half, 1.0f, near, far) *
                           glm::lookAt(position, position + forward, up);
      shadow.mapFromWorld = vp;
      shadow.params = glm::vec4(far, 2.0f * std::tan(half) / tile, 0.0f, 0.0f);
      plan.tileViewProjection.push_back(vp);
    } else {
      const glm::mat4 projection = glm::perspectiveRH_ZO(glm::radians(90.0f), 1.0f, near, far);
      for (size_t face = 0; face < 6; ++face) {
        plan.tileViewProjection.push_back(
            projection * glm::lookAt(position, position + kFaceForward[face], kFaceUp[face]));
      }
      shadow.params = glm::vec4(far, 2.0f / tile, 0.0f, 0.0f);
    }
    plan.lights.push_back(caster.index);
    plan.shadows.push_back(shadow);
  }
  const uint32_t tiles = static_cast<uint32_t>(plan.tileViewProjection.size());
  const uint32_t columns = std::min<uint32_t>(tiles, MYRIAD_SHADOW_ATLAS_COLUMNS);
  const uint32_t rows = (tiles + MYRIAD_SHADOW_ATLAS_COLUMNS - 1) / MYRIAD_SHADOW_ATLAS_COLUMNS;
  plan.atlas = {columns * plan.tileSize, rows * plan.tileSize};
  return plan;
}

ShadowMaps::ShadowMaps(gpu::Context& context)
    : context_(context),
      arena_(context, kShadowBlockSize),
      scrollArena_(context, kShadowBlockSize),
      atlasArena_(context, kShadowBlockSize) {
  VkFormatProperties properties;
  vkGetPhysicalDeviceFormatProperties(context.physicalDevice, kDepthFormat, &properties);
  const bool linear =
      properties.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
  VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  // Linear comparison filtering, where the device has it, makes each tap a 2x2 PCF.
  info.magFilter = info.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  info.compareEnable = VK_TRUE;
  // Lit where the surface is no farther from the light than the nearest occluder.
  info.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  info.maxLod = 0.0f;
  VK_CHECK(vkCreateSampler(context.device, &info, nullptr, &sampler_));
}

ShadowMaps::~ShadowMaps() { vkDestroySampler(context_.device, sampler_, nullptr); }

void ShadowMaps::ensureSun(const SunShadowFit& fit) {
  const VkExtent2D extent = fit.atlas();
  if (sun_.image != VK_NULL_HANDLE && sun_.extent.width == extent.width &&
      sun_.extent.height == extent.height) {
    return;
  }
  arena_.release();
  // Transfers: scrollSun copies what a moved cascade keeps.
  sun_ = arena_.createImage2D(extent, kDepthFormat,
                              VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                  VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
  sunReadable_ = false;
  sunScene_ = 0;
}

void ShadowMaps::ensureSunPlaceholder() {
  if (sun_.image == VK_NULL_HANDLE) {
    SunShadowFit placeholder;
    placeholder.tileSize = 1;
    ensureSun(placeholder);
  }
}

void ShadowMaps::recordSunUnused(VkCommandBuffer cmd) {
  if (sunReadable_) return;
  const gpu::ImageTransition toRead[] = {{&sun_, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                                          kShadowReaders, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                          VK_IMAGE_LAYOUT_UNDEFINED,
                                          VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, toRead);
  sunReadable_ = true;
}

VkDescriptorImageInfo ShadowMaps::sunDescriptor() const {
  return {sampler_, sun_.view, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

void ShadowMaps::ensureAtlas(VkExtent2D extent) {
  if (atlas_.image != VK_NULL_HANDLE && atlas_.extent.width == extent.width &&
      atlas_.extent.height == extent.height) {
    return;
  }
  atlasArena_.release();
  atlas_ = atlasArena_.createImage2D(extent, kDepthFormat,
                                     VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  atlasReadable_ = false;
}

void ShadowMaps::ensureAtlasPlaceholder() {
  if (atlas_.image == VK_NULL_HANDLE) ensureAtlas({1, 1});
}

VkDescriptorImageInfo ShadowMaps::atlasDescriptor() const {
  return {sampler_, atlas_.view, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
}

void ShadowMaps::recordAtlasUnused(VkCommandBuffer cmd) {
  if (atlasReadable_) return;
  const gpu::ImageTransition toRead[] = {{&atlas_, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                                          kShadowReaders, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                          VK_IMAGE_LAYOUT_UNDEFINED,
                                          VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, toRead);
  atlasReadable_ = true;
}


// One rendering over the whole atlas (cleared once), a viewport per tile: a tile's clip space
// maps onto its own square, and clipping keeps every draw inside it.
void ShadowMaps::recordLights(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                              const LightShadowPlan& plan) {
  beginShadowRendering(cmd, p, scene, atlas_);
  const float size = float(plan.tileSize);
  for (uint32_t t = 0; t < plan.tileViewProjection.size(); ++t) {
    const uint32_t x = (t % MYRIAD_SHADOW_ATLAS_COLUMNS) * plan.tileSize;
    const uint32_t y = (t / MYRIAD_SHADOW_ATLAS_COLUMNS) * plan.tileSize;
    const VkViewport viewport{float(x), float(y), size, size, 0.0f, 1.0f};
    const VkRect2D scissor{{int32_t(x), int32_t(y)}, {plan.tileSize, plan.tileSize}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    gpu_types::ShadowPush push{plan.tileViewProjection[t]};
    vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
    drawCasters(cmd, scene);
  }
  endShadowRendering(cmd, atlas_);
  atlasReadable_ = true;
}

void ShadowMaps::release() {
  arena_.release();
  sun_ = {};
  sunReadable_ = false;
  sunScene_ = 0;
  scrollArena_.release();
  scrollScratch_ = {};
  atlasArena_.release();
  atlas_ = {};
  atlasReadable_ = false;
}

uint64_t ShadowMaps::gpuMemoryBytes() const {
  return arena_.bytesAllocated() + scrollArena_.bytesAllocated() + atlasArena_.bytesAllocated();
}

}  // namespace myriad::render
