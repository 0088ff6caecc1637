// Full-screen compute passes the frame records by registration, and the image states their
// barriers are derived from.
//
// A registered pass is one file, render/frame_passes/NAME.cpp, defining
// `const FramePass& frame_passes::NAME()`: its timer name, its place in the frame, the images it
// reads and writes, its shader. CMake lists the directory and generates the table
// (registeredFramePasses), so adding one touches that file, its shader and the shader's line in
// shaders/CMakeLists.txt (docs/ARCHITECTURE.md, "Adding a full-screen compute pass"). The frame
// records it with the frame's pipeline layout and sets 0 and 1 bound, one thread per pixel, and
// writes the barriers before it from what it declares against the images' last use
// (FrameImageStates): the pass records none of its own.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <vulkan/vulkan.h>

#include "render/frame.h"
#include "shared_types.h"

namespace myriad::render {

struct FrameTargets;
class SceneBuffers;

// The frame images whose last use the passes after the lighting hand on to each other. Every
// other target is either read-only by then (the G-buffer: sampled since the G-buffer pass, by
// fragment and compute shaders) or a pass's own business (the markers' keys, the LDR target).
enum class FrameImage : uint32_t { Hdr, LightCount, Output };
inline constexpr size_t kFrameImages = 3;

// An image's last use in the frame so far: the stage and access of the command that last touched
// it, and the layout it left it in.
struct ImageState {
  VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 access = VK_ACCESS_2_NONE;
  VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// The state of an image just written in `layout`: GENERAL by a compute shader's stores, else as
// a colour attachment (what the lighting techniques and the blend pass leave).
ImageState writtenIn(VkImageLayout layout);

struct FrameImageStates {
  std::array<ImageState, kFrameImages> images{};
  ImageState& operator[](FrameImage image) { return images[static_cast<size_t>(image)]; }
  const ImageState& operator[](FrameImage image) const {
    return images[static_cast<size_t>(image)];
  }
};

// How a registered pass uses an image. Sampled reads go through the target set's sampled
// bindings (READ_ONLY_OPTIMAL); storage uses through its storage bindings (GENERAL):
// MYRIAD_BINDING_HDR_STORAGE, MYRIAD_BINDING_LIGHT_COUNT_STORAGE, MYRIAD_BINDING_OUTPUT.
enum class ImageAccess { Sampled, StorageRead, StorageWrite, StorageReadWrite };

struct ImageUse {
  FrameImage image;
  ImageAccess access;
};

// Where a registered pass runs. Hdr: on the lit picture, after the forward passes (blend,
// markers) and before the final pass tonemaps it. Output: on the finished output, after the final
// pass, anti-aliasing and the light-volumes overlay, before the readback. Neither runs in a label
// or motion frame (its output is the label or motion pass's).
enum class FramePassPlace { Hdr, Output };

struct FramePass {
  const char* name;          // its timer name: Server-Timing, Frame::passes, myriad-bench
  FramePassPlace place;
  int order = 0;             // among the passes of its place, lower first (then by name)
  std::vector<ImageUse> uses;
  std::span<const uint32_t> shader;  // spirv::NAME_comp (embedded_shaders.h)
  // Its shader's local_size_x and local_size_y: the dispatch covers the output's pixels.
  uint32_t groupSize = MYRIAD_PIXEL_GROUP;
  // Whether this frame records it; null: every frame that shows a picture.
  bool (*wanted)(const FrameSettings& settings, const SceneBuffers& scene) = nullptr;
};

// Every pass of render/frame_passes/, by place, then order, then name.
const std::vector<const FramePass*>& registeredFramePasses();

// Barriers from each image's state in `states` to `uses`, batched into one; `states` then holds
// the uses (a write's stage and access, or a read's when nothing is written).
void recordUseBarriers(VkCommandBuffer cmd, const FrameTargets& targets,
                       std::span<const ImageUse> uses, FrameImageStates& states);

}  // namespace myriad::render
