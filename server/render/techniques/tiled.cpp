// Tiled (Andersson 2011; Lauritzen 2010): one 16x16 workgroup per 16x16-pixel tile culls every
// light against its tile's frustum into shared memory, then shades its pixels from that list, in
// one dispatch (shaders/light_tiled.comp). Its lists live in shared memory; on the GPU it holds
// only the culling counters.
#include <memory>
#include <utility>
#include <vector>

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
      : Tiled(setup, std::make_shared<FeaturePipelines>(setup.context.device,
                                                        setup.pipelines.layout,
                                                        spirv::light_tiled_comp)) {
    requireWorkgroup(setup.context, MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE, MYRIAD_TILE_SIZE);
  }

  // Reads the G-buffer and lights; writes HDR and light counts (GENERAL layout) and the counters.
  // One step of a workgroup per tile: each tile culls every light on its own, so any range of
  // tiles can be shaded in a submission of its own (the counters add up across them).
  std::vector<Step> steps(const LightingPass& pass) const override {
    return {{"lighting", tiles(pass.targets.extent), false}};
  }

  void recordStep(const LightingPass& pass, uint32_t step, uint32_t first,
                  uint32_t count) override {
    (void)step;
    VkCommandBuffer cmd = pass.cmd;
    set_.bind(cmd);
    if (first == 0) {
      counters_.reset(cmd);
      gpu::memoryBarrier(cmd, kFillStage, VK_ACCESS_2_TRANSFER_WRITE_BIT, kComputeStage,
                         kStorageReadWrite);
      prepareLightingTargets(cmd, pass.targets);
    }
    const VkExtent2D e = pass.targets.extent;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, shade_->get(pass.shadingFeatures));
    if (pass.split) {
      // Ranges of tiles spread over the image: each costs what the ones measured before it did.
      scatteredTiles(e, MYRIAD_TILE_SIZE).dispatch(cmd, first, count);
    } else {
      gpu::dispatchGroupRange(cmd, gpu::groupCount(e.width, MYRIAD_TILE_SIZE),
                              gpu::groupCount(e.height, MYRIAD_TILE_SIZE), first, count);
    }
    if (first + count >= tiles(e)) counters_.makeHostVisible(cmd);
  }

  VkImageLayout lightingLayout() const override { return VK_IMAGE_LAYOUT_GENERAL; }

  // The split frame's own counters (and set 2 naming them); the pipelines are shared.
  std::unique_ptr<LightingTechnique> splitInstance(const TechniqueSetup& setup) override {
    return std::unique_ptr<LightingTechnique>(new Tiled(setup, shade_));
  }

  const gpu::Buffer* counters() const override { return &counters_.stats; }
  void report(CullingReport& report, const void* counters) const override {
    CullingCounters::read(counters, report);
  }

  uint64_t gpuMemoryBytes() const override { return counters_.arena.bytesAllocated(); }

 private:
  Tiled(const TechniqueSetup& setup, std::shared_ptr<FeaturePipelines> shade)
      : shade_(std::move(shade)), set_(setup.context, setup.pipelines), counters_(setup.context) {
    const CullingSet::Binding bindings[] = {{MYRIAD_BINDING_CULLING_STATS, &counters_.stats}};
    set_.write(bindings);
  }

  static uint32_t tiles(VkExtent2D e) {
    return gpu::groupCount(e.width, MYRIAD_TILE_SIZE) * gpu::groupCount(e.height, MYRIAD_TILE_SIZE);
  }

  // Specialised per frame (render/shading_features.h); shared with the split frame's instance.
  std::shared_ptr<FeaturePipelines> shade_;
  CullingSet set_;
  CullingCounters counters_;
};

}  // namespace

std::unique_ptr<LightingTechnique> createTiled(const TechniqueSetup& setup) {
  return std::make_unique<Tiled>(setup);
}

}  // namespace myriad::render
