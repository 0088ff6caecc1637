// The `motion` target (render::Target::Motion): screen-space motion vectors, in pixels, from the
// previous time (FrameSettings::previousCamera, previousPose) to the frame's. A pass after the
// raster G-buffer draws its opaque and alpha-tested surfaces again, depth-tested EQUAL against its
// depth (as the label pass does), each vertex placed both now and then: the camera's motion, the
// instances' (their previous placements) and the skins' and morphs' (the pre-pass wrote their
// previous positions: render/skinning.h) all come out of one projection difference. It draws
// straight into the frame's output: raw, dx, dy, 1 where a surface is, 0 (float32); else a
// false-colour picture (shaders/motion_view.frag).
#pragma once

#include <map>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "render/frame_targets.h"
#include "render/scene_buffers.h"

namespace myriad::render {

class MotionPass {
 public:
  // `sceneSetLayout`: the frame's set 0 (Pipelines::sceneSetLayout); `slots`: how many frame
  // slots record it (each gets its own set 1).
  MotionPass(gpu::Context& context, VkDescriptorSetLayout sceneSetLayout, uint32_t slots);
  ~MotionPass();
  MotionPass(const MotionPass&) = delete;
  MotionPass& operator=(const MotionPass&) = delete;

  // After the raster G-buffer pass (depth readable): writes t.output, leaving it a colour
  // attachment (the readback's source). `sceneSet` names the frame slot (its set 1 is rewritten).
  // `previous`: the scene's previous placements and positions (SceneBuffers::applyPrevious) are
  // this frame's; else nothing moved but the camera.
  void record(VkCommandBuffer cmd, const FrameTargets& t, const SceneBuffers& scene,
              VkDescriptorSet sceneSet, const glm::mat4& previousViewProjection, bool previous,
              const MeshDetail& detail);

 private:
  gpu::Context& context_;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline raw_ = VK_NULL_HANDLE;
  VkPipeline view_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::map<VkDescriptorSet, VkDescriptorSet> sets_;  // per frame slot (its scene set)
};

}  // namespace myriad::render
