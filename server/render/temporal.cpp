// Temporal anti-aliasing of a stream's frames: the histories and the resolve pass
// (render/temporal.h, shaders/temporal_resolve.comp).
#include "render/temporal.h"

#include <algorithm>
#include <array>
#include <vector>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "render/sub_frames.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

constexpr VkFormat kHistoryFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kHistoryDepthFormat = VK_FORMAT_R32_SFLOAT;
constexpr VkFormat kCurrentFormat = VK_FORMAT_R8G8B8A8_SRGB;
// Two pairs of RGBA16F + R32F, and the frame's picture copied as sRGB.
constexpr uint64_t kBytesPerPixel = 2 * (8 + 4) + 4;

uint64_t historyBytes(uint32_t width, uint32_t height) {
  return uint64_t(width) * height * kBytesPerPixel;
}

constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;

}  // namespace

TemporalHistories::TemporalHistories(gpu::Context& context, VkSampler nearest, VkSampler linear,
                                     std::function<void()> waitIdle)
    : context_(context), nearest_(nearest), linear_(linear), waitIdle_(std::move(waitIdle)) {
  VkDevice device = context.device;
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_TEMPORAL_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    const bool sampled = i <= MYRIAD_TEMPORAL_BINDING_HISTORY_DEPTH;
    bindings[i] = {i,
                   sampled ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER
                           : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                   1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(device, bindings);
  const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(gpu_types::TemporalPush)};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &setLayout_;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &push;
  VK_CHECK(vkCreatePipelineLayout(device, &info, nullptr, &layout_));
  pipeline_ = gpu::createComputePipeline(device, layout_, spirv::temporal_resolve_comp);

  // A set per frame slot: the renderer's slots and its split slot.
  constexpr uint32_t kSets = 8;
  const VkDescriptorPoolSize sizes[] = {
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, kSets * 4},
      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, kSets * (MYRIAD_TEMPORAL_BINDINGS - 4)}};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = kSets;
  poolInfo.poolSizeCount = 2;
  poolInfo.pPoolSizes = sizes;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &pool_));
}

TemporalHistories::~TemporalHistories() {
  VkDevice device = context_.device;
  histories_.clear();  // the renderer waited for its frames before destroying its state
  if (pipeline_) vkDestroyPipeline(device, pipeline_, nullptr);
  if (pool_) vkDestroyDescriptorPool(device, pool_, nullptr);
  if (layout_) vkDestroyPipelineLayout(device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device, setLayout_, nullptr);
}

uint64_t TemporalHistories::bytes() const {
  uint64_t sum = 0;
  for (const auto& [key, h] : histories_) sum += h.arena ? h.arena->bytesAllocated() : 0;
  return sum;
}

void TemporalHistories::release(uint64_t key) {
  auto it = histories_.find(key);
  if (it == histories_.end()) return;
  waitIdle_();
  histories_.erase(it);
}

void TemporalHistories::releaseAll() {
  if (histories_.empty()) return;
  waitIdle_();
  histories_.clear();
}

// Room for `incoming` more bytes and one more key: the least recently used go.
void TemporalHistories::evict(uint64_t incoming) {
  for (;;) {
    uint64_t held = 0;
    for (const auto& [key, h] : histories_) held += historyBytes(h.width, h.height);
    if (histories_.empty() ||
        (histories_.size() < kMaxHistories && held + incoming <= kMaxHistoryBytes)) {
      return;
    }
    auto oldest = std::min_element(histories_.begin(), histories_.end(), [](const auto& a, const auto& b) {
      return a.second.lastUsed < b.second.lastUsed;
    });
    waitIdle_();
    histories_.erase(oldest);
  }
}

FrameSettings TemporalHistories::plan(const FrameSettings& settings, TemporalFramePlan& out) {
  out = {};
  if (!settings.temporalHistory()) return settings;
  FrameSettings frame = settings;
  const uint64_t needed = historyBytes(settings.width, settings.height);
  if (needed > kMaxHistoryBytes) {
    frame.antialias = Antialias::None;  // too large to keep: the frame as none
    return frame;
  }
  auto it = histories_.find(settings.historyKey);
  if (it != histories_.end() &&
      (it->second.width != settings.width || it->second.height != settings.height)) {
    release(settings.historyKey);  // another size: made again
    it = histories_.end();
  }
  if (it == histories_.end()) {
    evict(needed);
    History h;
    h.width = settings.width;
    h.height = settings.height;
    h.generation = ++generations_;
    h.arena = std::make_unique<gpu::Arena>(context_, needed + (1u << 16));
    const VkExtent2D extent{settings.width, settings.height};
    constexpr VkImageUsageFlags usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                        VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    for (int i = 0; i < 2; ++i) {
      h.color[i] = h.arena->createImage2D(extent, kHistoryFormat, usage);
      h.depth[i] = h.arena->createImage2D(extent, kHistoryDepthFormat, usage);
    }
    // The output's format (the copy is a plain copy), read through an sRGB view.
    h.picture = h.arena->createImage2D(extent, kOutputFormat,
                                       VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                       1, VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT);
    h.pictureSrgb = h.arena->createView(h.picture, kCurrentFormat, VK_IMAGE_USAGE_SAMPLED_BIT);
    it = histories_.emplace(settings.historyKey, std::move(h)).first;
  }
  History& h = it->second;
  h.lastUsed = ++uses_;
  const scene::Camera& camera = settings.camera;
  const float aspect = float(settings.width) / float(settings.height);
  const glm::mat4 viewProjection = scene::projectionMatrix(camera, aspect) * scene::viewMatrix(camera);
  out.active = true;
  out.key = settings.historyKey;
  out.generation = h.generation;
  out.read = h.current;
  out.hasHistory = h.frames > 0;
  out.fresh = h.fresh;
  // A camera that stayed: exactly the identity (the product with the inverse is not, to float
  // rounding), so the pass reads the history texel for texel.
  out.reprojection = h.frames > 0 && h.viewProjection != viewProjection
                         ? h.viewProjection * glm::inverse(viewProjection)
                         : glm::mat4(1.0f);
  out.jitter = taaJitter(uint32_t(h.frames % kTaaSamples));
  // projectionMatrix's planes, clamped the same way.
  out.nearPlane = std::max(camera.nearPlane, 1e-6f);
  out.farPlane = std::max(camera.farPlane, out.nearPlane * 1.001f);
  frame.jitter = out.jitter;
  h.viewProjection = viewProjection;
  h.current = 1 - h.current;
  h.frames += 1;
  h.fresh = false;
  return frame;
}

bool TemporalHistories::holds(const TemporalFramePlan& plan, VkExtent2D extent) const {
  auto it = histories_.find(plan.key);
  return plan.active && it != histories_.end() && it->second.generation == plan.generation &&
         it->second.width == extent.width && it->second.height == extent.height;
}

bool TemporalHistories::record(VkCommandBuffer cmd, const FrameTargets& t,
                               const TemporalFramePlan& plan, VkDescriptorSet slotKey) {
  if (!holds(plan, t.extent)) return false;
  auto it = histories_.find(plan.key);
  const History& h = it->second;
  const uint32_t read = plan.read, write = 1 - plan.read;

  // The picture the final pass stored, copied into the history's sRGB image: the pass reads its
  // neighbourhood there (decoded to linear light by the sampler) while it writes the output.
  // (The previous frame's pass read it: every frame's commands start with a full barrier.)
  std::vector<gpu::ImageTransition> before = {
      {&t.output, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
       VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL},
      {&h.picture, kCompute, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
       VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL}};
  if (plan.fresh) {
    // New images: cleared, so that nothing read before the first frame's writes is garbage.
    for (int i = 0; i < 2; ++i) {
      for (const gpu::Image* image : {&h.color[i], &h.depth[i]}) {
        before.push_back({image, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                          VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
      }
    }
  }
  gpu::barrier(cmd, before);
  if (plan.fresh) {
    const VkClearColorValue zero{};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    for (int i = 0; i < 2; ++i) {
      vkCmdClearColorImage(cmd, h.color[i].image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
      vkCmdClearColorImage(cmd, h.depth[i].image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    }
  }
  VkImageCopy region{};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.dstSubresource = region.srcSubresource;
  region.extent = {t.extent.width, t.extent.height, 1};
  vkCmdCopyImage(cmd, t.output.image, VK_IMAGE_LAYOUT_GENERAL, h.picture.image,
                 VK_IMAGE_LAYOUT_GENERAL, 1, &region);
  const gpu::ImageTransition after[] = {
      {&h.picture, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL},
      {&t.output, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE, kCompute,
       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL}};
  gpu::barrier(cmd, after);
  // The history: written by the previous frame's pass (or cleared just now), read and written
  // here. (Every frame's commands also start with a full barrier; this one is the pass's own.)
  gpu::memoryBarrier(cmd, kCompute | VK_PIPELINE_STAGE_2_CLEAR_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                     VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);

  VkDescriptorSet& set = sets_[slotKey];
  if (!set) {
    VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    alloc.descriptorPool = pool_;
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &setLayout_;
    VK_CHECK(vkAllocateDescriptorSets(context_.device, &alloc, &set));
  }
  const VkDescriptorImageInfo infos[MYRIAD_TEMPORAL_BINDINGS] = {
      {nearest_, h.pictureSrgb, VK_IMAGE_LAYOUT_GENERAL},
      {nearest_, t.depth.view, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL},
      {linear_, h.color[read].view, VK_IMAGE_LAYOUT_GENERAL},
      {nearest_, h.depth[read].view, VK_IMAGE_LAYOUT_GENERAL},
      {VK_NULL_HANDLE, h.color[write].view, VK_IMAGE_LAYOUT_GENERAL},
      {VK_NULL_HANDLE, h.depth[write].view, VK_IMAGE_LAYOUT_GENERAL},
      {VK_NULL_HANDLE, t.output.view, VK_IMAGE_LAYOUT_GENERAL}};
  VkWriteDescriptorSet writes[MYRIAD_TEMPORAL_BINDINGS];
  for (uint32_t i = 0; i < MYRIAD_TEMPORAL_BINDINGS; ++i) {
    const bool sampled = i <= MYRIAD_TEMPORAL_BINDING_HISTORY_DEPTH;
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType =
        sampled ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    writes[i].pImageInfo = &infos[i];
  }
  vkUpdateDescriptorSets(context_.device, MYRIAD_TEMPORAL_BINDINGS, writes, 0, nullptr);

  gpu_types::TemporalPush push{};
  push.reprojection = plan.reprojection;
  push.jitter = glm::vec4(plan.jitter, 1.0f / float(t.extent.width), 1.0f / float(t.extent.height));
  push.params = glm::vec4(plan.nearPlane, plan.farPlane, plan.hasHistory ? 1.0f : 0.0f, kTaaBlend);
  push.limits = glm::vec4(kDisocclusionDepth, 0.0f, 0.0f, 0.0f);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, gpu::groupCount(t.extent.width, MYRIAD_PIXEL_GROUP),
                gpu::groupCount(t.extent.height, MYRIAD_PIXEL_GROUP), 1);
  return true;
}

}  // namespace myriad::render
