// Stochastic local shadows (settings.shadows.local = stochastic; docs/ARCHITECTURE.md, "Stochastic
// local shadows"): every local light casts a shadow, at one shadow ray per pixel. The renderer
// owns one StochasticShadows; a frame that asks for them
//   - builds or refits the BVH of the scene's triangles (render/bvh.h) after skinning, before the
//     G-buffer ("bvh-build" / "bvh-refit"),
//   - and the clustered technique's shading step (techniques/clustered.cpp) binds this pass
//     (shaders/shadow_rays_ris.comp) instead of its own: per pixel one light resampled from its
//     cluster's list by its unshadowed light, one shadow ray, the unbiased RIS estimate
//     ("shadow-rays").
// Where the sun casts shadows (settings.shadows.sun) the pass traces a ray towards it too, and no
// sun map is drawn. Not built yet: temporal and spatial reuse of the reservoirs (ReSTIR), a
// denoiser, textured alpha cut-outs (solid in the BVH).
#pragma once

#include <cstdint>
#include <memory>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "render/bvh.h"
#include "render/frame.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "render/shading_features.h"
#include "render/tuning.h"

namespace myriad::render {

class StochasticShadows {
 public:
  StochasticShadows(gpu::Context& context, const Pipelines& pipelines, const Tuning& tuning);
  ~StochasticShadows();
  StochasticShadows(const StochasticShadows&) = delete;
  StochasticShadows& operator=(const StochasticShadows&) = delete;

  // Whether a frame of `settings` traces its local lights' shadows: stochastic with the
  // clustered technique (the others shade stochastic as maps).
  static bool wanted(const FrameSettings& settings);

  // The frame's part of the uniforms (FrameUniforms.stochastic): zero unless wanted().
  void writeUniforms(gpu_types::FrameUniforms& u, const FrameSettings& settings,
                     const SceneBuffers& scene) const;

  // Before the lighting: the BVH for `scene` (Bvh::record). Binds its own compute sets: the
  // caller binds the frame's again. Must precede bindShade in every frame that traces.
  void recordBvh(VkCommandBuffer cmd, const SceneBuffers& scene, gpu::PassTimer& timer);

  // The shading pass in place of the clustered technique's: binds its pipeline for `features`
  // and the BVH's trace set (set 3 of its layout; sets 0-2 stay as the frame and the technique
  // bound them). The caller dispatches one MYRIAD_CLUSTER_SHADE_TILE-square workgroup per tile,
  // as for its own shading pass.
  void bindShade(VkCommandBuffer cmd, uint32_t features) const;

  uint64_t gpuMemoryBytes() const { return bvh_ ? bvh_->gpuMemoryBytes() : 0; }

 private:
  // The BVH, the pass's layout and pipelines: made by the first frame that traces (a renderer
  // that never does pays nothing, not even pipeline compilation).
  void create();

  gpu::Context& context_;
  const Pipelines& pipelines_;
  const Tuning tuning_;
  std::unique_ptr<Bvh> bvh_;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;  // sets 0-2 the frame's, 3 the BVH's trace set
  std::unique_ptr<FeaturePipelines> shade_;
};

}  // namespace myriad::render
