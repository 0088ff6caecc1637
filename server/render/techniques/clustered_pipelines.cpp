// The clustered technique's pipelines (ClusteredPipelines, techniques/clustered_lists.h) and
// the choices made with them.
#include "render/techniques/clustered_lists.h"

#include <algorithm>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "render/raster.h"

namespace myriad::render::clustered {

std::span<const uint32_t> shadeShaderFor(const Tuning& tuning, const gpu::DeviceInfo& device) {
  switch (tuning.shade) {
    case ShadePass::Subgroup:
      return spirv::light_clustered_subgroup_comp;
    case ShadePass::Whole:  // the pass for lists too long, as the device would choose it
      return device.computeSubgroupShuffle && !device.isCpu ? spirv::light_clustered_subgroup_comp
                                                            : spirv::light_clustered_comp;
    default:
      return spirv::light_clustered_comp;
  }
}

WholeLists wholeListsFor(const Tuning& tuning) {
  if (tuning.shade == ShadePass::Whole) return WholeLists::Always;
  if (tuning.shade == ShadePass::WholeWhenShort) return WholeLists::WhenShort;
  return WholeLists::Never;
}

uint32_t initialCapacity(const ClusterGrid& grid, uint32_t lightCount, uint64_t mostReferences) {
  uint64_t wanted = std::max({uint64_t(kMinimumListCapacity), uint64_t(lightCount) * kReferencesPerLight,
                              uint64_t(grid.count()) * kReferencesPerCluster});
  // lavapipe caps a storage buffer at 128 MiB: 32M references. Overflow beyond is reported.
  return static_cast<uint32_t>(std::min(wanted, mostReferences));
}

ClusteredPipelines::ClusteredPipelines(const TechniqueSetup& setup)
    : tuning(setup.tuning),
      list(setup.context.device),
      shade(setup.context.device, setup.pipelines.layout,
            shadeShaderFor(tuning, setup.context.info), tuning.shadeVariant),
      wholeLists(wholeListsFor(tuning)),
      binnedAssign(tuning.assign == AssignPath::Binned),
      animateInCount(binnedAssign && !tuning.animateSeparate),
      marksFromGBuffer(tuning.markInGBuffer),
      pointTestMode(tuning.pointTest.value_or(0)) {
  requireWorkgroup(setup.context, MYRIAD_SCAN_GROUP, MYRIAD_SCAN_GROUP);
  requireWorkgroup(setup.context, MYRIAD_ASSIGN_BIN_GROUP, MYRIAD_ASSIGN_BIN_GROUP);
  VkDevice device = setup.context.device;
  VkPipelineLayout layout = setup.pipelines.layout;
  if (wholeLists != WholeLists::Never) {
    shadeWhole = std::make_unique<FeaturePipelines>(device, layout,
                                                    spirv::light_clustered_whole_comp);
  }
  {
    // cluster_mark.comp: kNumber (constant 0), kPointTest (7: no bounds gathered when 0).
    const VkSpecializationMapEntry entries[] = {{0, 0, sizeof(VkBool32)},
                                                {7, sizeof(VkBool32), sizeof(uint32_t)}};
    for (VkBool32 numbering : {VK_FALSE, VK_TRUE}) {
      const uint32_t values[] = {numbering, pointTestMode};
      VkSpecializationInfo spec{2, entries, sizeof(values), values};
      (numbering ? number : mark) = list.add(
          gpu::createComputePipeline(device, layout, spirv::cluster_mark_comp, &spec));
    }
  }
  scan = list.add(gpu::createComputePipeline(device, layout, spirv::cluster_scan_comp));
  // Alpha-blended surfaces mark their clusters from their fragments (storage writes from a
  // fragment shader): without fragmentStoresAndAtomics the forward pass tests every light.
  if (setup.context.fragmentStores) {
    gpu::GraphicsPipelineDesc d;
    d.vertexShader = spirv::gbuffer_vert;
    d.fragmentShader = spirv::cluster_mark_blend_frag;
    d.vertexLayout = surfaceVertexLayout();
    d.depthFormat = kDepthFormat;
    d.depthTest = true;
    d.depthCompare = VK_COMPARE_OP_LESS;  // as the forward pass: its fragments are these
    d.cullMode = VK_CULL_MODE_NONE;       // both faces: a superset of what it draws
    markBlend = list.add(gpu::createGraphicsPipeline(device, layout, d));
  }
  // cluster_assign.comp counts (kAssign = false) or fills the lists (true): one source, so both
  // passes run the identical overlap test.
  // kLarge (constant 1) picks the per-light or the per-large-light (workgroup) variant.
  // kPointTest (7) the boxes a light is tested against (pointTest()).
  const VkSpecializationMapEntry entries[] = {{0, 0, sizeof(VkBool32)},
                                              {1, sizeof(VkBool32), sizeof(VkBool32)},
                                              {7, 2 * sizeof(VkBool32), sizeof(uint32_t)}};
  for (VkBool32 filling : {VK_FALSE, VK_TRUE}) {
    for (VkBool32 large : {VK_FALSE, VK_TRUE}) {
      const uint32_t values[] = {filling, large, pointTestMode};
      VkSpecializationInfo spec{3, entries, sizeof(values), values};
      VkPipeline& target = filling ? (large ? assignLarge : assign) : (large ? countLarge : count);
      target = list.add(
          gpu::createComputePipeline(device, layout, spirv::cluster_assign_comp, &spec));
    }
    // cluster_assign_binned.comp: kAssign (constant 0), its table's bins (2), kAnimate (3),
    // kMostClusters (5), the workgroup's size (6), kPointTest (7); each a 4-byte word.
    const VkSpecializationMapEntry binnedEntries[] = {
        {0, 0, 4}, {2, 4, 4}, {3, 8, 4}, {5, 12, 4}, {6, 16, 4}, {7, 20, 4}};
    for (VkBool32 animate : {VK_FALSE, VK_TRUE}) {
      if (filling && animate) continue;
      const uint32_t binnedValues[] = {filling, tuning.assignBins, animate,
                                       tuning.assignMostClusters, tuning.assignGroupSize,
                                       pointTestMode};
      VkSpecializationInfo binnedSpec{6, binnedEntries, sizeof(binnedValues), binnedValues};
      (filling ? assignBinned : animate ? countBinnedAnimated : countBinned) = list.add(
          gpu::createComputePipeline(device, layout, spirv::cluster_assign_binned_comp, &binnedSpec));
    }
  }
}

}  // namespace myriad::render::clustered
