#include "render/extra_targets.h"

#include <stdexcept>

#include "gpu/commands.h"
#include "shared_types.h"

namespace myriad::render {

using gpu::ImageTransition;

ExtraRegions extraRegionsOf(const FrameSettings& settings) {
  ExtraRegions r;
  for (Target t : settings.alsoRead) {
    if (isLabel(t)) {
      if (isLabel(settings.target)) {
        r.region.push_back(-1);  // the frame's own readback holds the label image
        continue;
      }
      if (r.labels < 0) r.labels = int(r.count++);
      r.region.push_back(r.labels);
    } else {
      r.region.push_back(int(r.count++));
    }
  }
  return r;
}

namespace {

void checkExtras(const FrameSettings& settings) {
  if (settings.alsoRead.size() > kMaxExtraTargets) {
    throw std::invalid_argument("a frame reads back at most " + std::to_string(kMaxExtraTargets) +
                                " targets besides its own");
  }
  for (size_t i = 0; i < settings.alsoRead.size(); ++i) {
    const Target t = settings.alsoRead[i];
    if (t == settings.target || t == Target::Final || t == Target::LightVolumes) {
      throw std::invalid_argument("alsoRead may not hold " + std::string(targetName(t)));
    }
    for (size_t j = 0; j < i; ++j) {
      if (settings.alsoRead[j] == t) throw std::invalid_argument("alsoRead repeats a target");
    }
    // The views pass reads the G-buffer as the frame's own views pass left it; a label main
    // target skips that pass, so views come with a view (or final) as the frame's own target.
    if (!isLabel(t) && isLabel(settings.target)) {
      throw std::invalid_argument("a label frame reads back no other view");
    }
  }
}

}  // namespace

void recordExtraTargets(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                        const FrameSettings& settings, const gpu::Buffer& uniforms,
                        VkDeviceSize flagsOffset, const uint32_t hostFlags[4],
                        VkPipelineLayout layout, VkDescriptorSet rawSet, ExtraDestination to) {
  checkExtras(settings);
  const ExtraRegions regions = extraRegionsOf(settings);
  if (regions.count == 0) return;
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  constexpr VkPipelineStageFlags2 kUniformReaders = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                                                    VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                                                    kCompute;
  const gpu::Image& output = t.raw ? t.output : t.extraOutput;
  if (!t.raw) {
    if (rawSet == VK_NULL_HANDLE) throw std::logic_error("an 8-bit frame's extras need a raw set");
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, MYRIAD_SET_TARGETS, 1,
                            &rawSet, 0, nullptr);
  }
  bool firstView = true;
  for (size_t i = 0; i < settings.alsoRead.size(); ++i) {
    const Target target = settings.alsoRead[i];
    if (isLabel(target) || regions.region[i] < 0) continue;
    // The view index is a uniform: rewritten on the GPU timeline after every earlier reader.
    gpu::memoryBarrier(cmd, kUniformReaders, VK_ACCESS_2_UNIFORM_READ_BIT,
                       VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const uint32_t flags[4] = {static_cast<uint32_t>(target), hostFlags[1], 1u, hostFlags[3]};
    vkCmdUpdateBuffer(cmd, uniforms.buffer, flagsOffset, sizeof flags, flags);
    gpu::bufferBarrier(cmd, uniforms, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, VK_ACCESS_2_UNIFORM_READ_BIT);
    // The output's previous use was a copy out of it (this frame's readback, or the previous
    // view's); its contents are not needed.
    const ImageTransition toStorage[] = {{&output, VK_PIPELINE_STAGE_2_COPY_BIT | kCompute,
                                          VK_ACCESS_2_NONE, kCompute,
                                          VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL}};
    gpu::barrier(cmd, toStorage);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.viewsFor(target, true));
    vkCmdDispatch(cmd, gpu::groupCount(t.extent.width, MYRIAD_PIXEL_GROUP),
                  gpu::groupCount(t.extent.height, MYRIAD_PIXEL_GROUP), 1);
    const ImageTransition toCopy[] = {{&output, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                       VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                                       VK_IMAGE_LAYOUT_GENERAL,
                                       VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}};
    gpu::barrier(cmd, toCopy);
    VkBufferImageCopy region{};
    region.bufferOffset = to.offset + t.regionBytes() * VkDeviceSize(regions.region[i]);
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {t.extent.width, t.extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, output.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           to.buffer->buffer, 1, &region);
    firstView = false;
  }
  (void)firstView;
  if (regions.labels >= 0) {
    const ImageTransition toCopy[] = {{&t.labels, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                                       VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                       VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                                       VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                                       VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}};
    gpu::barrier(cmd, toCopy);
    VkBufferImageCopy region{};
    region.bufferOffset = to.offset + t.regionBytes() * VkDeviceSize(regions.labels);
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {t.extent.width, t.extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, t.labels.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           to.buffer->buffer, 1, &region);
  }
  gpu::bufferBarrier(cmd, *to.buffer, VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
}

void readExtraTargets(const FrameTargets& t, const FrameSettings& settings, Frame& frame,
                      const uint8_t* lent) {
  frame.extras.clear();
  frame.labels = {};
  frame.extrasCopy.reset();
  const ExtraRegions regions = extraRegionsOf(settings);
  if (regions.count == 0) return;
  const size_t floats = size_t(t.extent.width) * t.extent.height * 4;
  const float* base = reinterpret_cast<const float*>(lent);
  if (base == nullptr) {
    // Copied once, every region together (a vector of the size would be zeroed first: a second
    // pass over 16 bytes a pixel, on the render thread).
    const auto* mapped = static_cast<const float*>(t.extraReadback.mapped);
    auto copy = std::make_shared<const std::vector<float>>(mapped, mapped + floats * regions.count);
    base = copy->data();
    frame.extrasCopy = std::move(copy);
  }
  for (size_t i = 0; i < settings.alsoRead.size(); ++i) {
    if (isLabel(settings.alsoRead[i]) || regions.region[i] < 0) continue;
    frame.extras.push_back({settings.alsoRead[i],
                            {base + floats * size_t(regions.region[i]), floats}});
  }
  if (regions.labels >= 0) frame.labels = {base + floats * size_t(regions.labels), floats};
}

}  // namespace myriad::render
