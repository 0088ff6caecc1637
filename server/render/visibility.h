// The G-buffer rasterised in compute (GBufferPath::Compute; docs/ARCHITECTURE.md, "The G-buffer
// in compute"). Three passes write exactly what recordGBufferPass writes, so every later pass is
// the same whichever path ran:
//   visibility  one thread per triangle: transform, cull, clip, then cover the pixel centres of a
//               small triangle's box with 64-bit atomicMin(depth bits << 32 | triangle id), or
//               queue a large one;
//   (tiles)     an indirect dispatch, one workgroup per (64x64 tile, queued triangle);
//   resolve     one thread per pixel: the triangle's barycentrics from the pixel ray, the
//               vertex attributes and the material (material_core.glsl, the raster path's code)
//               into the G-buffer's storage views; depth through a buffer copied into the depth
//               target (a depth image is no storage image).
// On GPUs where few units run fragment shaders (4 of 132 SMs on the H200) the raster path's
// cost is fragment shading; these passes run on every SM.
#pragma once

#include <memory>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame_targets.h"
#include "render/scene_buffers.h"

namespace myriad::render {

class ComputeGBuffer {
 public:
  // `sceneSetLayout`: set 0 of the frame's layout (Pipelines::sceneSetLayout), shared with these
  // passes' own layout so the frame's set 0 stays bound. `slots`: frame slots that record with it.
  ComputeGBuffer(gpu::Context& context, VkDescriptorSetLayout sceneSetLayout, uint32_t slots);
  ~ComputeGBuffer();
  ComputeGBuffer(const ComputeGBuffer&) = delete;
  ComputeGBuffer& operator=(const ComputeGBuffer&) = delete;

  // The device can: 64-bit integers and buffer atomics, and the G-buffer's formats as storage
  // images. Without it nothing is created and every frame takes the raster path.
  bool supported() const { return supported_; }
  // Whether a frame of `scene` at `extent` can take this path: supported, every material the
  // G-buffer draws opaque and untextured (no descriptor indexing on lavapipe: one texture set
  // per draw is the raster path's), the buffers within the storage-buffer range.
  bool qualifies(const SceneBuffers& scene, VkExtent2D extent) const;

  // What one frame slot records with: the per-pixel keys and depth, the tile pass's queue, the
  // frame's draw table (host-written each frame: the slot's last frame has finished) and its
  // descriptor set. Sized to the frame and the draws; rebuilt when they outgrow it.
  struct Slot {
    explicit Slot(gpu::Context& context) : arena(context, 4ull << 20) {}
    gpu::Arena arena;
    VkExtent2D extent{0, 0};
    uint32_t drawCapacity = 0;
    gpu::Buffer keys;   // uint64 per pixel
    gpu::Buffer depth;  // float per pixel
    gpu::Buffer large;  // VisibilityLargeHeader, then the queue
    gpu::Buffer draws;  // uvec4 header, then one per draw (Upload)
    VkDescriptorSet set = VK_NULL_HANDLE;  // allocated once per slot
  };
  // Records the three passes into `cmd`, timing them as "visibility" and "resolve"; leaves the
  // G-buffer and depth as recordGBufferPass does, and the compute bind point's sets disturbed
  // (the caller binds the frame's again). The optional targets are written where
  // FrameUniforms.written says, as in recordGBufferPass.
  // `sceneSet`: the frame's set 0 (bound again with these passes' layout).
  void record(VkCommandBuffer cmd, std::unique_ptr<Slot>& slot, const FrameTargets& targets,
              const SceneBuffers& scene, VkDescriptorSet sceneSet, gpu::PassTimer& timer);

 private:
  gpu::Context& context_;
  bool supported_ = false;
  VkDeviceSize maxStorageRange_ = 0;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline visibility_ = VK_NULL_HANDLE;
  VkPipeline tiles_ = VK_NULL_HANDLE;
  VkPipeline resolve_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
};

}  // namespace myriad::render
