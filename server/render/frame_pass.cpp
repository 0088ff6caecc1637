#include "render/frame_pass.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "gpu/commands.h"
#include "render/frame_targets.h"

// One `const FramePass& NAME();` per file of render/frame_passes/, listed by CMake
// (server/render/CMakeLists.txt) as MYRIAD_FRAME_PASS(NAME) lines.
#define MYRIAD_FRAME_PASS(name) const FramePass& name();
namespace myriad::render::frame_passes {
#include "render/frame_pass_list.inc"
}  // namespace myriad::render::frame_passes
#undef MYRIAD_FRAME_PASS

namespace myriad::render {

namespace {

constexpr VkAccessFlags2 kWrites =
    VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
    VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
    VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_HOST_WRITE_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;

const gpu::Image& imageOf(const FrameTargets& t, FrameImage image) {
  switch (image) {
    case FrameImage::Hdr:
      return t.hdr;
    case FrameImage::LightCount:
      return t.lightCount;
    case FrameImage::Output:
      return t.output;
  }
  throw std::logic_error("no frame image " + std::to_string(static_cast<uint32_t>(image)));
}

const char* imageName(FrameImage image) {
  switch (image) {
    case FrameImage::Hdr:
      return "hdr";
    case FrameImage::LightCount:
      return "lightCount";
    default:
      return "output";
  }
}

}  // namespace

ImageState writtenIn(VkImageLayout layout) {
  if (layout == VK_IMAGE_LAYOUT_GENERAL) {
    return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, layout};
  }
  return {VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          layout};
}

const std::vector<const FramePass*>& registeredFramePasses() {
  static const std::vector<const FramePass*> passes = [] {
    std::vector<const FramePass*> list;
#define MYRIAD_FRAME_PASS(name) list.push_back(&frame_passes::name());
#include "render/frame_pass_list.inc"
#undef MYRIAD_FRAME_PASS
    std::stable_sort(list.begin(), list.end(), [](const FramePass* a, const FramePass* b) {
      if (a->place != b->place) return a->place < b->place;
      if (a->order != b->order) return a->order < b->order;
      return std::strcmp(a->name, b->name) < 0;
    });
    return list;
  }();
  return passes;
}

void recordUseBarriers(VkCommandBuffer cmd, const FrameTargets& targets,
                       std::span<const ImageUse> uses, FrameImageStates& states) {
  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  std::vector<gpu::ImageTransition> transitions;
  for (const ImageUse& use : uses) {
    ImageState& state = states[use.image];
    if (state.layout == VK_IMAGE_LAYOUT_UNDEFINED) {
      // Nothing this frame wrote it yet (the output before the final pass): its contents would
      // be whatever the last frame left.
      throw std::logic_error(std::string("a registered pass uses ") + imageName(use.image) +
                             " before the frame wrote it");
    }
    VkAccessFlags2 access = VK_ACCESS_2_NONE;
    switch (use.access) {
      case ImageAccess::Sampled:
        access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
        break;
      case ImageAccess::StorageRead:
        access = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
        break;
      case ImageAccess::StorageWrite:
        access = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
        break;
      case ImageAccess::StorageReadWrite:
        access = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
        break;
    }
    const VkImageLayout layout = use.access == ImageAccess::Sampled
                                     ? VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL
                                     : VK_IMAGE_LAYOUT_GENERAL;
    const bool writes = (access & kWrites) != 0;
    // Reads after reads in the same layout need nothing: the barrier before the first read
    // made the last write visible to compute shaders.
    if (layout != state.layout || writes || (state.access & kWrites) != 0) {
      transitions.push_back({&imageOf(targets, use.image), state.stage, state.access, kCompute,
                             access, state.layout, layout});
    }
    if (writes || layout != state.layout) {
      state = {kCompute, access, layout};
    } else {
      // A read: the next user still waits for the last write, and for this read.
      state.stage |= kCompute;
      state.access |= access;
    }
  }
  if (!transitions.empty()) gpu::barrier(cmd, transitions);
}

}  // namespace myriad::render
