// Clustered (Olsson, Billeter, Assarsson 2012): the cluster grid (render/cluster_grid.h) gets
// compact per-cluster light lists built on the GPU each frame, and each pixel walks its
// cluster's list. Five steps: mark the clusters holding visible geometry (the compute G-buffer's
// resolve sets their bits where it runs) and number them, count each active
// cluster's lights (per workgroup in shared memory, then once per cluster globally; lights
// reaching many clusters a workgroup each), place each cluster's list (cut at the capacity,
// overflow counted), fill the lists (timed together as "assign"), shade ("shade": each 16x16 tile first
// narrows its clusters' lists to the lights reaching the bounds of its own pixels, in shared
// memory, then walks them per pixel or per subgroup; on CPU devices, while the lists are short,
// each pixel walks its cluster's whole list instead (kWholeListsUpTo); shaders/cluster_*.comp,
// light_clustered.comp, light_clustered_whole.comp, light_clustered_subgroup.comp).
//
// The lists are sized from the output and the light count; when a frame overflows them and they
// may still grow, growLists() makes them 1.25 x what the frame needed and the renderer renders
// that frame again; the grown size is kept for later frames.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "render/cluster_grid.h"
#include "render/raster.h"
#include "render/shading_features.h"
#include "render/stochastic_shadows.h"
#include "render/techniques/clustered_lists.h"
#include "render/techniques/compute_lighting.h"
#include "render/techniques/technique.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::groupCount;
using namespace clustered;

class Clustered final : public LightingTechnique {
 public:
  explicit Clustered(const TechniqueSetup& setup)
      : Clustered(setup, std::make_shared<ClusteredPipelines>(setup)) {}

  // The lists follow the output size, the light count and what they grew to; they are rebuilt
  // only when those change. Sessions' scenes take turns: lists that hold what this frame wants,
  // without more than twice the waste, stay, so frames of a 1,000-light and a 100,000-light scene
  // in turn do not reallocate them every frame.
  void prepare(VkExtent2D extent, uint32_t lightCount) override {
    const uint64_t mostReferences = maxListBytes() / sizeof(uint32_t);
    const ClusterGrid grid = clusterGrid(extent, p_->tuning);
    uint32_t capacity = initialCapacity(grid, lightCount, mostReferences);
    if (listStartCapacity_ > 0) capacity = listStartCapacity_;
    capacity = static_cast<uint32_t>(
        std::min<uint64_t>(std::max(capacity, grownListCapacity_), mostReferences));
    const bool keep = lists_ && lists_->grid == grid && lists_->capacity >= capacity &&
                      lists_->capacity <= 2 * uint64_t(capacity) &&
                      lists_->capacity <= mostReferences && lists_->lightCapacity >= lightCount;
    if (keep) return;
    lists_.reset();
    lists_ = std::make_unique<ClusterLists>(context_, grid, capacity, lightCount,
                                            pairBytes(lightCount), forSplit_);
    const CullingSet::Binding bindings[] = {
        {MYRIAD_BINDING_CLUSTER_RANGES, &lists_->ranges},
        {MYRIAD_BINDING_CLUSTER_LIGHTS, &lists_->lists},
        {MYRIAD_BINDING_CULLING_STATS, &counters_.stats},
        {MYRIAD_BINDING_CLUSTER_CURSORS, &lists_->cursors},
        {MYRIAD_BINDING_LARGE_LIGHTS, &lists_->large},
        {MYRIAD_BINDING_CLUSTER_PAIRS, &lists_->pairs},
    };
    set_.write(bindings);
  }

  void writeUniforms(FrameUniforms& u) const override {
    u.flags.w = lists_->capacity;
    // The compute G-buffer's resolve marks the clusters, and gathers their points' bounds where
    // the light test reads them.
    u.written.z = !p_->marksFromGBuffer
                      ? 0u
                      : MYRIAD_RESOLVE_MARKS | (p_->pointTestMode != 0 ? MYRIAD_RESOLVE_BOUNDS : 0u);
  }

  // On GPUs the counting pass moves the lights as it walks them: one pass over the lights fewer.
  bool animatesLights() const override { return p_->animateInCount; }

  // Reads the G-buffer and lights; builds the cluster lists (mark, count, scan, assign), then
  // writes HDR and light counts (GENERAL layout) and the counters. Timed as two parts, "assign"
  // (steps 1-4, building the lists) and "shade" (step 5), or step by step (assign-steps).
  // The passes over lights (per-light counting and filling) and the shading (a workgroup per
  // 16x16 tile) may be recorded in ranges; the rest is whole.
  enum StepIndex : uint32_t { kMark, kCount, kCountLarge, kScan, kFill, kFillLarge, kShade };
  std::vector<Step> steps(const LightingPass& pass) const override {
    const bool detail = p_->tuning.assignSteps;
    const uint32_t lights = pass.scene.lightCount;
    // The large lights' passes: one indirect dispatch, or in parts ranges of its groups.
    const uint32_t largeLights = lights == 0 ? 0u : pass.split ? MYRIAD_LARGE_LIGHT_GROUPS : 1u;
    const uint32_t smallLights =
        lights == 0 ? 0u : p_->binnedAssign ? 1u : groupCount(lights, MYRIAD_LIGHTS_PER_GROUP);
    return {{"assign", 1},
            {detail ? "assign-count" : "assign", smallLights},
            {detail ? "assign-count-large" : "assign", largeLights},
            {detail ? "assign-scan" : "assign", 1},
            {detail ? "assign-fill" : "assign", smallLights},
            {detail ? "assign-fill-large" : "assign", largeLights},
            {pass.stochastic ? "shadow-rays" : "shade", shadeTiles(pass.targets.extent), false}};
  }

  void recordStep(const LightingPass& pass, uint32_t step, uint32_t first,
                  uint32_t count) override {
    VkCommandBuffer cmd = pass.cmd;
    const FrameTargets& t = pass.targets;
    const ClusteredPipelines& p = *p_;
    set_.bind(cmd);
    const bool animate = pass.animateLights && pass.scene.lightCount > 0;
    const VkPipelineStageFlags2 lightReaders = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                                               VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kComputeStage;
    switch (step) {
      case kMark: {
        copiesRecorded_ = {};  // this frame's copies of the queue and the ranges: none yet
        // Every cluster starts inactive: the last frame's scan left the cursors so, and new lists
        // get it once here. The mark pass empties the counters and the large-light queue.
        VkPipelineStageFlags2 before = 0;
        if (!lists_->cursorsInactive) {
          // Cursors, counts and numbers MYRIAD_CLUSTER_INACTIVE, no cluster numbered yet.
          const VkDeviceSize numbered = VkDeviceSize(lists_->grid.count()) * 16;
          vkCmdFillBuffer(cmd, lists_->cursors.buffer, 0, numbered, MYRIAD_CLUSTER_INACTIVE);
          vkCmdFillBuffer(cmd, lists_->cursors.buffer, numbered, 4, 0);
          lists_->cursorsInactive = true;
          before = kFillStage;
        }
        // Moving the lights here: their readers before in the frame (none today) finish first;
        // the last frame's are behind the renderer's barrier before the lighting.
        if (animate) before |= lightReaders;
        if (before != 0) {
          gpu::memoryBarrier(cmd, before,
                             (before & kFillStage) != 0 ? VK_ACCESS_2_TRANSFER_WRITE_BIT
                                                        : VK_ACCESS_2_NONE,
                             kComputeStage, kStorageReadWrite);
        }
        // 1. Mark clusters holding visible geometry (the compute G-buffer's resolve did, or a
        // pass over the pixels here), then number them (a cluster an invocation).
        if (p.tuning.assignSteps) pass.timer.beginPass(cmd, "assign-mark");
        if (!(pass.computeGBuffer && p.marksFromGBuffer)) {
          dispatchPixels(cmd, p.mark, t.extent, MYRIAD_PIXEL_GROUP);
          gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
        }
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.number);
        vkCmdDispatch(cmd, groupCount(lists_->grid.count(), MYRIAD_PIXEL_GROUP * MYRIAD_PIXEL_GROUP),
                      1, 1);
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
        // 1b. And those of alpha-blended surfaces in front of it (or over the background).
        if (p.markBlend != VK_NULL_HANDLE && hasBlendDraws(pass.scene)) markBlendClusters(cmd, pass);
        break;
      }
      case kCount:
        // 2. Count each active cluster's lights: small lights a thread each, queueing the large
        // ones, then the queue a workgroup per light (an indirect dispatch of the queue's length).
        dispatchSmallLights(cmd, pass.scene.lightCount, p.count,
                            animate ? p.countBinnedAnimated : p.countBinned, first, count);
        // With the lights moved, their later readers too (markers' vertex and the blend pass's
        // fragment shaders).
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite,
                           kComputeStage | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT |
                               (animate ? lightReaders : 0),
                           kStorageReadWrite | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
        // A split frame reads how many large lights were queued (unitsWithWork).
        if (pass.split && first + count >= steps(pass)[kCount].units &&
            lists_->largeCopy.buffer != VK_NULL_HANDLE) {
          gpu::bufferBarrier(cmd, lists_->large, kComputeStage, kStorageWrite,
                             VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
          const VkBufferCopy region{0, 0, sizeof(LargeLightQueue)};
          vkCmdCopyBuffer(cmd, lists_->large.buffer, lists_->largeCopy.buffer, 1, &region);
          gpu::bufferBarrier(cmd, lists_->largeCopy, VK_PIPELINE_STAGE_2_COPY_BIT,
                             VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                             VK_ACCESS_2_HOST_READ_BIT);
          copiesRecorded_.queue = true;
        }
        break;
      case kCountLarge:
        dispatchLargeLights(cmd, pass, p.countLarge, first, count);
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
        break;
      case kScan:
        // 3. Prefix sum: list offsets, capacity cuts, counters.
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.scan);
        vkCmdDispatch(cmd,
                      groupCount(lists_->grid.count(), MYRIAD_SCAN_GROUP * MYRIAD_SCAN_CLUSTERS_PER_THREAD),
                      1, 1);
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
        break;
      case kFill:
        // 4. Fill the lists: the same split, the queue kept from step 2.
        dispatchSmallLights(cmd, pass.scene.lightCount, p.assign, p.assignBinned, first, count);
        // The small-light pass does not write the queue, and its list slots are not the large
        // lights', but it holds both writable: order it before the indirect read and the large
        // lights' pass all the same (the synchronization layer's rule).
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite,
                           kComputeStage | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                           kStorageReadWrite | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
        break;
      case kFillLarge:
        dispatchLargeLights(cmd, pass, p.assignLarge, first, count);
        gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage,
                           VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
        // The lists are complete: a split frame reads the overflow before it shades from them,
        // and the lists' lengths to size its ranges of tiles (unitWeights).
        if (pass.split) {
          counters_.makeHostVisible(cmd);
          if (lists_->rangesCopy.buffer != VK_NULL_HANDLE) {
            gpu::bufferBarrier(cmd, lists_->ranges, kComputeStage, kStorageWrite,
                               VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
            const VkBufferCopy region{0, 0, lists_->ranges.size};
            vkCmdCopyBuffer(cmd, lists_->ranges.buffer, lists_->rangesCopy.buffer, 1, &region);
            gpu::bufferBarrier(cmd, lists_->rangesCopy, VK_PIPELINE_STAGE_2_COPY_BIT,
                               VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                               VK_ACCESS_2_HOST_READ_BIT);
            copiesRecorded_.ranges = true;
          }
        }
        break;
      case kShade: {
        // 5. Shade every pixel from its cluster's list, narrowed per tile (or whole:
        // kWholeListsUpTo).
        if (first == 0) prepareLightingTargets(cmd, t);
        const bool whole = p.wholeLists == WholeLists::Always ||
                           (p.wholeLists == WholeLists::WhenShort &&
                            p_->lastLongestList.load(std::memory_order_relaxed) <= kWholeListsUpTo);
        FeaturePipelines& shade = whole ? *p_->shadeWhole : p_->shade;
        if (pass.stochastic) {
          // Stochastic local shadows: the same tiles, each pixel one shadow ray.
          pass.stochastic->bindShade(cmd, pass.shadingFeatures);
        } else {
          vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, shade.get(pass.shadingFeatures));
        }
        if (pass.split) {
          // Ranges of tiles spread over the image (unitWeights weighs them in this order).
          scatteredTiles(t.extent, MYRIAD_CLUSTER_SHADE_TILE).dispatch(cmd, first, count);
        } else {
          gpu::dispatchGroupRange(cmd, groupCount(t.extent.width, MYRIAD_CLUSTER_SHADE_TILE),
                                  groupCount(t.extent.height, MYRIAD_CLUSTER_SHADE_TILE), first,
                                  count);
        }
        if (first + count >= shadeTiles(t.extent)) counters_.makeHostVisible(cmd);
        break;
      }
      default:
        throw std::logic_error("clustered lighting has no step " + std::to_string(step));
    }
  }

  VkImageLayout lightingLayout() const override { return VK_IMAGE_LAYOUT_GENERAL; }

  // The split frame's own lists, counters and set 2; the pipelines are shared.
  std::unique_ptr<LightingTechnique> splitInstance(const TechniqueSetup& setup) override {
    auto instance = std::unique_ptr<Clustered>(new Clustered(setup, p_));
    instance->forSplit_ = true;
    instance->listLimitBytes_ = listLimitBytes_;
    instance->listStartCapacity_ = listStartCapacity_;
    return instance;
  }

  // After the large lights' fill every list is complete (or cut at the capacity).
  bool listsBuiltAfter(uint32_t step) const override { return step == kFillLarge; }

  // The large lights' passes: a workgroup a queued light (looping when there are more). The
  // fill keeps one, so that the step that completes the lists always runs (listsBuiltAfter).
  uint32_t unitsWithWork(uint32_t step, uint32_t units) const override {
    if ((step != kCountLarge && step != kFillLarge) || !copiesRecorded_.queue) return units;
    LargeLightQueue queue;
    std::memcpy(&queue, lists_->largeCopy.mapped, sizeof(queue));
    const uint32_t queued = std::min(units, queue.queued.x);
    return step == kFillLarge ? std::max(queued, 1u) : queued;
  }

  // A shading tile costs about its pixels times the lights each walks: the longest list of the
  // clusters above it (any slice; its pixels' slices are not known here), plus a pixel's own
  // work (worth a few lights). From the split frame's copy of the lists' ranges.
  std::vector<float> unitWeights(uint32_t step, VkExtent2D extent) const override {
    if (step != kShade || !copiesRecorded_.ranges) return {};
    constexpr float kPixelWork = 4.0f;
    const ClusterGrid& g = lists_->grid;
    const auto* ranges = static_cast<const uint32_t*>(lists_->rangesCopy.mapped);
    std::vector<uint32_t> longest(size_t(g.x) * g.y, 0);
    for (uint32_t z = 0; z < g.slices; ++z) {
      for (uint32_t i = 0; i < g.x * g.y; ++i) {
        const uint32_t kept = ranges[2 * (size_t(z) * g.x * g.y + i) + 1];
        if (kept != MYRIAD_CLUSTER_INACTIVE) longest[i] = std::max(longest[i], kept);
      }
    }
    const uint32_t clusterTile = p_->tuning.clusterTile;
    const std::vector<std::pair<uint32_t, uint32_t>> order =
        scatteredTiles(extent, MYRIAD_CLUSTER_SHADE_TILE).order();
    std::vector<float> weights(order.size());
    for (size_t i = 0; i < order.size(); ++i) {
      const uint32_t cx = std::min(order[i].first * MYRIAD_CLUSTER_SHADE_TILE / clusterTile, g.x - 1);
      const uint32_t cy = std::min(order[i].second * MYRIAD_CLUSTER_SHADE_TILE / clusterTile, g.y - 1);
      weights[i] = kPixelWork + float(longest[size_t(cy) * g.x + cx]);
    }
    return weights;
  }

  bool bindForwardLights(VkCommandBuffer cmd) const override {
    if (p_->markBlend == VK_NULL_HANDLE) return false;
    set_.bindGraphics(cmd);
    return true;
  }

  const gpu::Buffer* counters() const override { return &counters_.stats; }
  void report(CullingReport& report, const void* counters) const override {
    CullingCounters::read(counters, report);
    p_->lastLongestList.store(report.mostLightsInList, std::memory_order_relaxed);
    report.listBytes = lists_->bytes();
    report.listCapacity = lists_->capacity;
  }

  // A frame with lights missing is never the answer while memory allows.
  bool growLists(const CullingReport& c) override {
    const uint64_t mostReferences = maxListBytes() / sizeof(uint32_t);
    if (c.clusterLightsDropped == 0 || c.listCapacity >= mostReferences ||
        c.listCapacity >= failedListCapacity_) {
      return false;
    }
    const uint64_t needed = uint64_t(c.listEntries) + c.clusterLightsDropped;
    const auto grown = static_cast<uint64_t>(std::ceil(double(needed) * kListGrowth));
    previousListCapacity_ = grownListCapacity_;
    grownListCapacity_ = static_cast<uint32_t>(
        std::min({grown, mostReferences, uint64_t(failedListCapacity_) - 1}));
    return true;
  }

  // Out of device memory for the larger lists: the frame we had is the answer (its overflow is
  // reported) and that size is not tried again.
  void growthFailed() override {
    failedListCapacity_ = grownListCapacity_;
    grownListCapacity_ = previousListCapacity_;
  }

  void limitListMemory(uint64_t bytes, uint64_t startBytes) override {
    listLimitBytes_ = bytes;
    listStartCapacity_ =
        static_cast<uint32_t>(std::min<uint64_t>(startBytes / sizeof(uint32_t), UINT32_MAX));
    grownListCapacity_ = 0;
    failedListCapacity_ = UINT32_MAX;
  }

  uint64_t gpuMemoryBytes() const override {
    return counters_.arena.bytesAllocated() + (lists_ ? lists_->arena.bytesAllocated() : 0);
  }

 private:
  Clustered(const TechniqueSetup& setup, std::shared_ptr<ClusteredPipelines> pipelines)
      : context_(setup.context), p_(std::move(pipelines)), set_(setup.context, setup.pipelines),
        counters_(setup.context) {}

  // Workgroups of the shading pass (a 16x16 tile each).
  static uint32_t shadeTiles(VkExtent2D e) {
    return groupCount(e.width, MYRIAD_CLUSTER_SHADE_TILE) *
           groupCount(e.height, MYRIAD_CLUSTER_SHADE_TILE);
  }

  // The large lights' count or fill pass: an indirect dispatch of the queue's groups, or in a
  // split frame groups [first, first + count) of the most it may have (dispatch base).
  void dispatchLargeLights(VkCommandBuffer cmd, const LightingPass& pass, VkPipeline pipeline,
                           uint32_t first, uint32_t count) const {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    if (pass.split) {
      gpu::dispatchGroupRange(cmd, MYRIAD_LARGE_LIGHT_GROUPS, 1, first, count);
    } else {
      vkCmdDispatchIndirect(cmd, lists_->large.buffer, 0);
    }
  }

  // The small lights' count or fill pass: per light (`perLight`, one thread each; workgroups
  // [first, first + count) of them) or per workgroup run (`binned`, whole), as binnedAssign says.
  void dispatchSmallLights(VkCommandBuffer cmd, uint32_t lightCount, VkPipeline perLight,
                           VkPipeline binned, uint32_t first, uint32_t count) const {
    if (p_->binnedAssign) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, binned);
      vkCmdDispatch(cmd, binnedGroups(lightCount), 1, 1);
    } else {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, perLight);
      gpu::dispatchGroupRange(cmd, groupCount(lightCount, MYRIAD_LIGHTS_PER_GROUP), 1, first, count);
    }
  }

  // The blended draws, depth-tested against the G-buffer without writing it, write 0 (active) into
  // the cursor of each fragment's cluster (cluster_mark_blend.frag).
  void markBlendClusters(VkCommandBuffer cmd, const LightingPass& pass) const {
    const VkPipelineStageFlags2 fragment = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, fragment, kStorageReadWrite);
    VkRenderingAttachmentInfo depth = readOnlyDepth(pass.targets.depth);
    beginRendering(cmd, pass.targets.extent, {}, &depth);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p_->markBlend);
    set_.bindGraphics(cmd);
    bindGeometry(cmd, pass.scene);
    for (const DrawItem& draw : pass.scene.draws) {
      if (!pass.scene.blend[draw.material]) continue;
      vkCmdDrawIndexed(cmd, draw.mesh.indexCount, 1, draw.mesh.firstIndex, draw.mesh.vertexOffset,
                       draw.instance);
    }
    vkCmdEndRendering(cmd);
    gpu::memoryBarrier(cmd, fragment, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kComputeStage,
                       kStorageReadWrite);
  }

  uint64_t maxListBytes() const {
    uint64_t device = context_.info.maxStorageBufferRange;
    return listLimitBytes_ > 0 ? std::min(listLimitBytes_, device) : device;
  }

  // The workgroups of the binned passes for `lightCount` lights (at least one): at most
  // tuning.assignGroups (the multiprocessors or kBinnedAssignGroups), each taking at least
  // tuning.assignGroupLights (kBinnedGroupLights); --tune assign-groups and assign-group-lights
  // are benchmark experiments.
  uint32_t binnedGroups(uint32_t lightCount) const {
    const Tuning& tuning = p_->tuning;
    const uint32_t most = tuning.assignGroups.value_or(kBinnedAssignGroups);
    return std::clamp(groupCount(lightCount, tuning.assignGroupLights), 1u, most);
  }

  // The pair buffer of cluster_assign_binned.comp for `lightCount` lights: a count and a table per
  // workgroup, then pairSlotsPerLight(tuning) slots per light (within the device's storage range). The
  // lists are kept for fewer lights: the passes then run fewer groups, whose regions are larger.
  VkDeviceSize pairBytes(uint32_t lightCount) const {
    if (!p_->binnedAssign) return 4;
    const uint64_t groups = binnedGroups(lightCount);
    const Tuning& tuning = p_->tuning;
    const uint64_t tables = groups * (1 + uint64_t(tuning.assignBins)) * 4;
    const uint64_t slotBytes = kPairWordsPerSlot * 4;
    // The floor only with the default slots: an override is there to fill the regions.
    const uint64_t floor = tuning.assignPairSlots ? 1 : kMinimumPairSlots;
    const uint64_t wanted =
        std::max(uint64_t(lightCount) * pairSlotsPerLight(tuning), floor) * slotBytes;
    const uint64_t room = context_.info.maxStorageBufferRange - tables;
    return tables + std::min(wanted, room / slotBytes * slotBytes);
  }

  gpu::Context& context_;
  std::shared_ptr<ClusteredPipelines> p_;
  CullingSet set_;
  CullingCounters counters_;
  bool forSplit_ = false;  // the split frame's instance (splitInstance): keeps rangesCopy
  // What the frame being recorded copied for the host so far (the split frame's instance; the
  // copies are read once the part that made them completed).
  struct {
    bool queue = false;   // largeCopy, after the count
    bool ranges = false;  // rangesCopy, after the fill
  } copiesRecorded_;
  std::unique_ptr<ClusterLists> lists_;
  uint64_t listLimitBytes_ = 0;              // limitListMemory(); 0 = the device's limit
  uint32_t listStartCapacity_ = 0;           // limitListMemory(); 0 = initialCapacity()'s
  uint32_t grownListCapacity_ = 0;           // what overflowing lists grew to (kept)
  uint32_t previousListCapacity_ = 0;        // before the last growLists()
  uint32_t failedListCapacity_ = UINT32_MAX;  // lists this large could not be allocated
};

}  // namespace

std::unique_ptr<LightingTechnique> createClustered(const TechniqueSetup& setup) {
  return std::make_unique<Clustered>(setup);
}

}  // namespace myriad::render

