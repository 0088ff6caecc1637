// Tiled (Andersson 2011; Lauritzen 2010): one 16x16 workgroup per 16x16-pixel tile culls every
// light against its tile's frustum into shared memory, then shades its pixels from that list, in
// one dispatch (shaders/light_tiled.comp). Its lists live in shared memory; on the GPU it holds
// only the culling counters.
#include <memory>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "render/shading_features.h"
#include "render/techniques/compute_lighting.h"
#include "render/techniques/technique.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

class Tiled final : public LightingTechnique {
 public:
  explicit Tiled(const TechniqueSetup& setup)
      : shade_(setup.context.device, setup.pipelines.layout, spirv::light_tiled_comp),
        set_(setup.context, setup.pipelines), counters_(setup.context) {
    requireWorkgroup(setup.context, MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE, MYRIAD_TILE_SIZE);
    const CullingSet::Binding bindings[] = {{MYRIAD_BINDING_CULLING_STATS, &counters_.stats}};
    set_.write(bindings);
  }

  // Reads the G-buffer and lights; writes HDR and light counts (GENERAL layout) and the counters.
  VkImageLayout record(const LightingPass& pass) override {
    VkCommandBuffer cmd = pass.cmd;
    pass.timer.beginPass(cmd, "lighting");
    set_.bind(cmd);
    counters_.reset(cmd);
    gpu::memoryBarrier(cmd, kFillStage, VK_ACCESS_2_TRANSFER_WRITE_BIT, kComputeStage,
                       kStorageReadWrite);
    prepareLightingTargets(cmd, pass.targets);
    dispatchPixels(cmd, shade_.get(pass.shadingFeatures), pass.targets.extent, MYRIAD_TILE_SIZE);
    counters_.makeHostVisible(cmd);
    return VK_IMAGE_LAYOUT_GENERAL;
  }

  const gpu::Buffer* counters() const override { return &counters_.stats; }
  void report(CullingReport& report, const void* counters) const override {
    CullingCounters::read(counters, report);
  }

  uint64_t gpuMemoryBytes() const override { return counters_.arena.bytesAllocated(); }

 private:
  FeaturePipelines shade_;  // specialised per frame (render/shading_features.h)
  CullingSet set_;
  CullingCounters counters_;
};

}  // namespace

std::unique_ptr<LightingTechnique> createTiled(const TechniqueSetup& setup) {
  return std::make_unique<Tiled>(setup);
}

}  // namespace myriad::render
