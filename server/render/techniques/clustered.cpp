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
#include "render/techniques/compute_lighting.h"
#include "render/techniques/technique.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

using gpu::groupCount;

// Light references per light the lists are sized for. A light small next to a 64-pixel tile
// touches 1-4 tiles and 1-2 slices; lights near the camera touch many more but are few. Eight per
// light covered the built-in scenes at every tested size with room to spare (the culling report
// says when it does not); the floor keeps small scenes from being starved by a few huge lights.
constexpr uint32_t kReferencesPerLight = 8;
constexpr uint32_t kMinimumListCapacity = 1u << 18;
// References per cluster of the whole grid. Per light alone is not enough when the lights are
// dense or the output large: on the H200 the lists overflowed at 3840x2160 with 10,000 and
// 100,000 floor lights and at 1920x1080 in the built-in scene with 10,000 (bench/history/),
// needing 400-450 references per active cluster. About 4-5% of clusters hold geometry in those
// views, so 32 per grid cluster leaves 650-800 per active one: 2 MiB at 1080p, 8 MiB at 4K.
constexpr uint32_t kReferencesPerCluster = 32;

// Overflowing lists grow to this much more than the frame needed, so a view that moves a little
// does not overflow again on the next frame.
constexpr double kListGrowth = 1.25;

// The lists are a few MiB at most sizes; the 64 MiB default block would be mostly waste.
constexpr VkDeviceSize kListBlockSize = 4ull << 20;

// The small lights' count and fill passes (cluster_assign_binned.comp) run at most one workgroup
// per multiprocessor of the device (DeviceInfo::multiprocessors), or this many where the driver
// does not say, each taking a contiguous run of the lights: the more lights a workgroup counts,
// the fewer global atomics its shared table leaves (each group flushes its table once). The pass
// takes as long as the busiest multiprocessor: on the H200 (132 SMs) 128 groups beat 64, 96, 192,
// 256, 512, 1,024 and 2,048 with a million lights at 1080p and at 4K (bench/history/, issue
// 16 stop 16): fewer leave SMs idle, more give some SMs two groups' lights.
constexpr uint32_t kBinnedAssignGroups = 128;
// And at least this many lights a workgroup (its subgroups share them, and a subgroup of few
// lights walks their clusters side by side all the same): 10,000 lights get 128 groups, not 40
// (H200: assign 0.081 -> 0.064 ms at 1080p, stop 16).
constexpr uint32_t kBinnedGroupLights = 64;
// The binned passes' workgroups are this large where the device allows: both passes wait on
// memory most of the time, and a multiprocessor runs one group, so its invocations are all it has
// to hide that with. On the H200, a million lights at 1080p, assign: 256 invocations 0.239 ms,
// 512 0.144, 1,024 0.122 (issue 16, stop 17).
constexpr uint32_t kBinnedGroupSize = 1024;
// The pair buffer holds at least this many slots, so that a few thousand lights with large boxes
// are still recorded, not queued for the large-light passes.
constexpr uint64_t kMinimumPairSlots = 1u << 20;

// The knobs below (render/tuning.h, set by --tune) arrive resolved for the device in
// TechniqueSetup::tuning; the comments say why each default is what it is.

// Pair slots (cluster_assign_binned.comp) per light: a light reserves a slot for each cluster of
// its box, reached or not (its pairs are recorded one after another). A light whose box finds its
// workgroup's region full is walked by the large-light passes instead, so fewer slots are slower,
// never wrong. --tune assign-pair-slots=1..64 overrides it: a benchmark experiment, and a test's
// way to send lights down the full region's path.
constexpr uint64_t kPairSlotsPerLight = 8;
uint64_t pairSlotsPerLight(const Tuning& tuning) {
  return tuning.assignPairSlots ? *tuning.assignPairSlots : kPairSlotsPerLight;
}
constexpr uint64_t kPairWordsPerSlot = 3;  // light, cluster (or bin), rank

// The binned passes' shared-table bins (active clusters counted in shared memory):
// tuning.assignBins, MYRIAD_ASSIGN_BINS unless --tune assign-bins says otherwise.
// The binned passes' workgroup size: tuning.assignGroupSize (kBinnedGroupSize's 1,024 unless
// --tune assign-group-size asks for 256 or 512), halved by resolveTuning() while the device runs
// no groups that large (never below MYRIAD_ASSIGN_BIN_GROUP, which the technique requires).
static_assert(Tuning{}.assignGroupSize == kBinnedGroupSize);
static_assert(Tuning{}.assignGroupLights == kBinnedGroupLights);
// Lights whose box holds more clusters than tuning.assignMostClusters (MYRIAD_LARGE_LIGHT_CLUSTERS
// unless --tune assign-most-clusters says otherwise) go to the large-light passes.

// Whether the small lights are counted per workgroup in shared memory (cluster_assign_binned.comp)
// or with one global atomic per light-cluster pair (cluster_assign.comp). Binned on GPUs, where
// the busiest cluster's per-pair atomics were serialised; per pair on CPU devices, where atomics
// are cheap and binned's third walk of every light doubled lavapipe's assignment of 10,000
// built-in lights (bench/history/). --tune assign=atomic|binned overrides it (the benchmark
// compares the two; technique_tests holds them to the same lists); the binned passes need full
// subgroups with arithmetic, ballot and shuffle (their walk per subgroup), so without them
// resolveTuning() keeps the per-pair path.
// --tune assign-steps=on: the benchmark times the assignment's steps apart ("assign" then holds
// the buffer clears only; "assign-mark", "-count", "-count-large", "-scan", "-fill",
// "-fill-large" the rest). A diagnostic: the extra timestamps wait for the work before them.
// --tune animate-separate=on: the binned counting pass leaves moving the lights to the renderer's
// animate pass (light_animate.comp), as the per-pair path always does (a benchmark comparison).
// Step 1 from the compute G-buffer's marks where it ran (its resolve pass reads every pixel's
// depth anyway: a bit per cluster, then one invocation per cluster here) instead of a pass over
// the pixels. --tune mark-in-gbuffer=off keeps the pixel pass (a benchmark comparison, and
// technique_tests' second renderer).
// The overlap test's boxes (cluster_assign.glsl's kPointTest): 2, the bounds of a cluster's
// surface points; --tune point-test=1 those and the cluster's view box, 0 the view box only (the
// test before stop 18). CPU devices default to 0, and their mark pass then gathers no bounds
// (cluster_mark.comp's kPointTest): on llvmpipe the gathering's atomics and barriers, run for
// every pixel, took a 1280x720 still's assign from 8-12 ms to 38-46 (bench/history/, stop 18),
// more than the shorter lists save the whole-list shading (about 10 ms). The lights that reach a
// pixel, so the image, are the same either way.

// The shading pass: each subgroup walking its tile's narrowed lists together
// (light_clustered_subgroup.comp) where compute shaders have the subgroup operations it needs,
// else each pixel on its own (light_clustered.comp; CPU devices too: on lavapipe the subgroup walk
// was slower). --tune shade=pixel|subgroup|whole overrides it (the benchmark compares them;
// technique_tests holds them to the same light counts).
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

// CPU devices shade from the clusters' whole lists, without the tile's narrowing
// (light_clustered_whole.comp), while the longest list of the last frame reported had at most
// this many lights. On lavapipe (2 cores, built-in scene at 1280x720, myriad-bench, stop 17): 256
// lights, longest list 22, shade 83-85 ms whole against 114-115 narrowed; 1,024 lights, longest
// 78: 224 against 267; 4,096 lights, longest 297: 1,263 against 875.
constexpr uint32_t kWholeListsUpTo = 96;

// Whether the technique keeps the whole-list pass: CPU devices (ShadePass::WholeWhenShort),
// unless --tune shade names a pass (whole: always that one; pixel or subgroup: never).
enum class WholeLists { Never, WhenShort, Always };
WholeLists wholeListsFor(const Tuning& tuning) {
  if (tuning.shade == ShadePass::Whole) return WholeLists::Always;
  if (tuning.shade == ShadePass::WholeWhenShort) return WholeLists::WhenShort;
  return WholeLists::Never;
}

// The subgroup pass's walk (MYRIAD_SHADE_* bits of shared_types.h): tuning.shadeVariant,
// MYRIAD_SHADE_DEFAULT unless --tune shade-variant asks for another (a benchmark experiment, and
// technique_tests' way to run the walk before stop 16, 0).

// The capacity a grid of `grid` with `lightCount` lights starts with, at most `mostReferences`.
uint32_t initialCapacity(const ClusterGrid& grid, uint32_t lightCount, uint64_t mostReferences) {
  uint64_t wanted = std::max({uint64_t(kMinimumListCapacity), uint64_t(lightCount) * kReferencesPerLight,
                              uint64_t(grid.count()) * kReferencesPerCluster});
  // lavapipe caps a storage buffer at 128 MiB: 32M references. Overflow beyond is reported.
  return static_cast<uint32_t>(std::min(wanted, mostReferences));
}

// The grid's buffers, recreated together when the grid or the capacity changes.
struct ClusterLists {
  ClusterLists(gpu::Context& context, const ClusterGrid& g, uint32_t references, uint32_t lights,
               VkDeviceSize pairBytes, bool readableRanges)
      : grid(g), capacity(references), lightCapacity(lights), arena(context, kListBlockSize) {
    const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    ranges = arena.createBuffer(VkDeviceSize(grid.count()) * 8,
                                storage | (readableRanges ? VK_BUFFER_USAGE_TRANSFER_SRC_BIT : 0),
                                gpu::MemoryUse::DeviceLocal);
    if (readableRanges) {
      rangesCopy = arena.createBuffer(ranges.size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                      gpu::MemoryUse::Readback);
      largeCopy = arena.createBuffer(sizeof(LargeLightQueue), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                     gpu::MemoryUse::Readback);
    }
    // Four words per cluster: the cursor, the count of pairs not recorded (clusterSpill), its
    // number among the active clusters, the cluster numbered so; then the active clusters' count
    // (and three words' padding), then two vec4 per cluster: the bounds of its surface points
    // (shaders/cluster_cursors.glsl).
    cursors = arena.createBuffer(VkDeviceSize(grid.count()) * 48 + 16,
                                 storage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUse::DeviceLocal);
    pairs = arena.createBuffer(pairBytes, storage, gpu::MemoryUse::DeviceLocal);
    lists = arena.createBuffer(VkDeviceSize(capacity) * 4, storage, gpu::MemoryUse::DeviceLocal);
    large = arena.createBuffer(sizeof(LargeLightQueue) + VkDeviceSize(std::max(lightCapacity, 1u)) * 4,
                               storage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                   (readableRanges ? VK_BUFFER_USAGE_TRANSFER_SRC_BIT : 0),
                               gpu::MemoryUse::DeviceLocal);
  }

  uint64_t bytes() const { return ranges.size + cursors.size + lists.size + large.size + pairs.size; }

  ClusterGrid grid;
  uint32_t capacity;  // light references all lists together can hold
  uint32_t lightCapacity;  // lights the large-light queue can hold
  gpu::Arena arena;
  gpu::Buffer ranges;   // uvec2 per cluster: first index, count
  gpu::Buffer cursors;  // uint per cluster: count, then fill cursor
  gpu::Buffer lists;    // uint per light reference
  gpu::Buffer large;    // LargeLightQueue, then a uint per queued light
  gpu::Buffer pairs;    // the binned passes' recorded pairs (one word when they do not run)
  // The split frame's: host-readable copies of `ranges` once the lists are built, and of the
  // large lights' queue header once they are counted (unitsWithWork).
  gpu::Buffer rangesCopy;
  gpu::Buffer largeCopy;
  bool cursorsInactive = false;  // the cursors hold MYRIAD_CLUSTER_INACTIVE (after the first frame)
};

// The pipelines of the technique, and the choices made with them: made once, shared by the
// whole frames' instance and the split frame's (Clustered::splitInstance).
struct ClusteredPipelines {
  explicit ClusteredPipelines(const TechniqueSetup& setup)
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

  const Tuning tuning;  // resolved for the device (render/tuning.h)
  PipelineList list;
  VkPipeline mark = VK_NULL_HANDLE;    // cluster_mark.comp's pixel pass
  VkPipeline number = VK_NULL_HANDLE;  // its numbering pass (kNumber)
  VkPipeline count = VK_NULL_HANDLE;
  VkPipeline scan = VK_NULL_HANDLE;
  VkPipeline assign = VK_NULL_HANDLE;
  VkPipeline countLarge = VK_NULL_HANDLE;   // the queued large lights, a workgroup each
  VkPipeline assignLarge = VK_NULL_HANDLE;
  VkPipeline countBinned = VK_NULL_HANDLE;  // cluster_assign_binned.comp
  VkPipeline countBinnedAnimated = VK_NULL_HANDLE;  // the same, moving the lights (kAnimate)
  VkPipeline assignBinned = VK_NULL_HANDLE;
  FeaturePipelines shade;  // specialised per frame (render/shading_features.h)
  WholeLists wholeLists;
  std::unique_ptr<FeaturePipelines> shadeWhole;  // light_clustered_whole.comp, unless Never
  VkPipeline markBlend = VK_NULL_HANDLE;  // null without fragmentStoresAndAtomics
  bool binnedAssign;  // small lights by cluster_assign_binned.comp (else cluster_assign.comp)
  bool animateInCount;  // animatesLights()
  bool marksFromGBuffer;  // the compute G-buffer's resolve marks the clusters (mark-in-gbuffer)
  uint32_t pointTestMode;  // the boxes lights are tested against (point-test; bounds unless 0)
  // The longest list of the last frame reported (any scene, either instance; unknown at first):
  // the whole-list pass is chosen from it, and a choice made from another scene's or an older
  // frame's lists costs time only (both passes make the same image).
  std::atomic<uint32_t> lastLongestList{UINT32_MAX};
};

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
