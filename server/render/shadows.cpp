#include "render/shadows.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu/commands.h"
#include "gpu/vk_check.h"
#include "render/frame_targets.h"
#include "render/raster.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

// A map is a few MiB (2048^2 x 4 B = 16 MiB): blocks the size of what they hold.
constexpr VkDeviceSize kShadowBlockSize = 1ull << 20;

// Everything that samples a shadow map: the sun pass (fragment) and compute lighting.
constexpr VkPipelineStageFlags2 kShadowReaders =
    VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;

}  // namespace

SunShadowFit fitSunShadow(const scene::Bounds& bounds, glm::vec3 direction, uint32_t size) {
  const glm::vec3 lo = bounds.empty() ? glm::vec3(-1.0f) : bounds.min;
  const glm::vec3 hi = bounds.empty() ? glm::vec3(1.0f) : bounds.max;
  const glm::vec3 center = 0.5f * (lo + hi);
  // The bounds' sphere: its square, seen from any direction, holds the whole scene, so the fit
  // depends on the scene and the sun only.
  const float radius = std::max(0.5f * glm::length(hi - lo), 1e-3f);
  const glm::vec3 d = glm::normalize(direction);
  const glm::vec3 up = std::abs(d.y) > 0.99f ? glm::vec3(0.0f, 0.0f, 1.0f) : glm::vec3(0.0f, 1.0f, 0.0f);
  // A little beyond the sphere so nothing touches the near or far plane.
  const float reach = radius * 1.01f;
  const glm::mat4 view = glm::lookAt(center - d * reach, center, up);
  const glm::mat4 projection = glm::orthoRH_ZO(-reach, reach, -reach, reach, 0.0f, 2.0f * reach);
  SunShadowFit fit;
  fit.viewProjection = projection * view;
  // Clip x, y in [-1, 1] -> u, v in [0, 1] (clip y = -1 is the map's first row, v = 0); depth as is.
  const glm::mat4 toUv = glm::translate(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, 0.0f)) *
                         glm::scale(glm::mat4(1.0f), glm::vec3(0.5f, 0.5f, 1.0f));
  fit.mapFromWorld = toUv * fit.viewProjection;
  fit.texelWorld = 2.0f * reach / float(size);
  return fit;
}

ShadowMaps::ShadowMaps(gpu::Context& context) : context_(context), arena_(context, kShadowBlockSize) {
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

void ShadowMaps::ensureSun(uint32_t size) {
  if (sun_.image != VK_NULL_HANDLE && sun_.extent.width == size) return;
  arena_.release();
  sun_ = arena_.createImage2D({size, size}, kDepthFormat,
                              VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  sunReadable_ = false;
}

void ShadowMaps::ensureSunPlaceholder() {
  if (sun_.image == VK_NULL_HANDLE) ensureSun(1);
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

void ShadowMaps::recordSun(VkCommandBuffer cmd, const Pipelines& p, const SceneBuffers& scene,
                           const glm::mat4& viewProjection) {
  // The previous frame's lighting sampled the map; its contents are rewritten whole.
  const gpu::ImageTransition before[] = {
      {&sun_, kShadowReaders, VK_ACCESS_2_NONE,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL}};
  gpu::barrier(cmd, before);
  VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depth.imageView = sun_.view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  beginRendering(cmd, sun_.extent, {}, &depth);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.shadow);
  gpu_types::ShadowPush push{viewProjection};
  vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
  bindGeometry(cmd, scene);
  // Every instance casts, whatever its material: both faces (a single-sided wall still blocks
  // the sun), and alpha-masked cut-outs cast as solid (no fragment shader).
  for (const DrawItem& draw : scene.draws) {
    vkCmdDrawIndexed(cmd, draw.mesh.indexCount, 1, draw.mesh.firstIndex, draw.mesh.vertexOffset,
                     draw.instance);
  }
  vkCmdEndRendering(cmd);
  const gpu::ImageTransition after[] = {
      {&sun_, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kShadowReaders,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
       VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, after);
  sunReadable_ = true;
}

void ShadowMaps::release() {
  arena_.release();
  sun_ = {};
  sunReadable_ = false;
}

uint64_t ShadowMaps::gpuMemoryBytes() const { return arena_.bytesAllocated(); }

}  // namespace myriad::render
