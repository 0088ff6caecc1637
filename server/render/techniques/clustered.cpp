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
#include <cstdlib>
#include <cstring>
#include <memory>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "render/cluster_grid.h"
#include "render/raster.h"
#include "render/shading_features.h"
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
// 100,000 floor lights and at 1920x1080 in the built-in scene with 10,000 (docs/performance.md),
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
// 256, 512, 1,024 and 2,048 with a million lights at 1080p and at 4K (docs/performance.md, issue
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

// The benchmark's experiment switches below read the environment once each through these.
bool envIs(const char* name, const char* value) {
  const char* v = std::getenv(name);
  return v && std::strcmp(v, value) == 0;
}
// The environment variable `name` as a number, or 0 when unset or not one.
uint64_t envNumber(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::strtoull(v, nullptr, 10) : 0;
}

// Pair slots (cluster_assign_binned.comp) per light: a light reserves a slot for each cluster of
// its box, reached or not (its pairs are recorded one after another). A light whose box finds its
// workgroup's region full is walked by the large-light passes instead, so fewer slots are slower,
// never wrong.
// MYRIAD_ASSIGN_PAIR_SLOTS (1 to 64) overrides it: a benchmark experiment, and a test's way to
// send lights down the full region's path.
uint64_t pairSlotsPerLight() {
  static const uint64_t slots = [] {
    const uint64_t n = envNumber("MYRIAD_ASSIGN_PAIR_SLOTS");
    return n >= 1 && n <= 64 ? n : uint64_t(8);
  }();
  return slots;
}
constexpr uint64_t kPairWordsPerSlot = 3;  // light, cluster (or bin), rank

// The shared table's bins of the binned passes (active clusters counted in shared memory):
// MYRIAD_ASSIGN_BINS, or MYRIAD_ASSIGN_BINS_OVERRIDE (256 to 4096; a benchmark experiment).
uint32_t assignBins() {
  static const uint32_t bins = [] {
    const uint64_t n = envNumber("MYRIAD_ASSIGN_BINS_OVERRIDE");
    return n >= 256 && n <= 4096 ? uint32_t(n) : uint32_t(MYRIAD_ASSIGN_BINS);
  }();
  return bins;
}

// The binned passes' workgroup size: kBinnedGroupSize, halved while the device runs no groups
// that large (never below MYRIAD_ASSIGN_BIN_GROUP, which the technique requires).
// MYRIAD_ASSIGN_BIN_GROUP_SIZE (256, 512 or 1,024) asks for another: a benchmark experiment.
uint32_t binnedGroupSize(const gpu::DeviceInfo& device) {
  const uint32_t most =
      std::min(device.maxComputeWorkGroupInvocations, device.maxComputeWorkGroupSizeX);
  const uint64_t asked = envNumber("MYRIAD_ASSIGN_BIN_GROUP_SIZE");
  uint32_t size =
      asked == 256 || asked == 512 || asked == 1024 ? uint32_t(asked) : kBinnedGroupSize;
  while (size > MYRIAD_ASSIGN_BIN_GROUP && size > most) size /= 2;
  return size;
}

// Lights whose box holds more clusters than this go to the large-light passes (a workgroup each):
// MYRIAD_LARGE_LIGHT_CLUSTERS, or MYRIAD_ASSIGN_MOST_CLUSTERS (1 to 65536; a benchmark experiment).
uint32_t mostClustersPerLight() {
  static const uint32_t most = [] {
    const uint64_t n = envNumber("MYRIAD_ASSIGN_MOST_CLUSTERS");
    return n >= 1 && n <= 65536 ? uint32_t(n) : uint32_t(MYRIAD_LARGE_LIGHT_CLUSTERS);
  }();
  return most;
}

// Whether the small lights are counted per workgroup in shared memory (cluster_assign_binned.comp)
// or with one global atomic per light-cluster pair (cluster_assign.comp). Binned on GPUs, where
// the busiest cluster's per-pair atomics were serialised; per pair on CPU devices, where atomics
// are cheap and binned's third walk of every light doubled lavapipe's assignment of 10,000
// built-in lights (docs/performance.md). MYRIAD_CLUSTER_ASSIGN=atomic|binned overrides it (the
// benchmark compares the two; technique_tests holds them to the same lists).
// MYRIAD_ASSIGN_STEPS=1: the benchmark times the assignment's steps apart ("assign" then holds
// the buffer clears only; "assign-mark", "-count", "-count-large", "-scan", "-fill",
// "-fill-large" the rest). A diagnostic: the
// extra timestamps wait for the work before them.
bool assignSteps() {
  static const bool on = envIs("MYRIAD_ASSIGN_STEPS", "1");
  return on;
}

// MYRIAD_ANIMATE_SEPARATE=1: the binned counting pass leaves moving the lights to the renderer's
// animate pass (light_animate.comp), as the per-pair path always does (a benchmark comparison).
bool separateAnimation() {
  return envIs("MYRIAD_ANIMATE_SEPARATE", "1");
}

// Step 1 from the compute G-buffer's marks where it ran (its resolve pass reads every pixel's depth
// anyway: a bit per cluster, then one invocation per cluster here) instead of a pass over the
// pixels. MYRIAD_MARK_IN_GBUFFER=0 keeps the pixel pass (a benchmark comparison, and
// technique_tests' second renderer). Read when the technique is made, not once a process: a test
// makes both renderers in one process.
bool markInGBuffer() {
  return !envIs("MYRIAD_MARK_IN_GBUFFER", "0");
}

// The overlap test's boxes (cluster_assign.glsl's kPointTest): 2, the bounds of a cluster's
// surface points; MYRIAD_CLUSTER_POINT_TEST=1 those and the cluster's view box, 0 the view box
// only (the test before stop 18): a benchmark switch. CPU devices default to 0, and their mark
// pass then gathers no bounds (cluster_mark.comp's kPointTest): on llvmpipe the gathering's
// atomics and barriers, run for every pixel, took a 1280x720 still's assign from 8-12 ms to
// 38-46 (docs/performance.md, stop 18), more than the shorter lists save the whole-list shading
// (about 10 ms). The lights that reach a pixel, so the image, are the same either way.
// Read when the technique is made, as the other switches a test sets for a second renderer.
uint32_t pointTest(const gpu::DeviceInfo& device) {
  if (!std::getenv("MYRIAD_CLUSTER_POINT_TEST")) return device.isCpu ? 0u : 2u;
  return static_cast<uint32_t>(std::min<uint64_t>(envNumber("MYRIAD_CLUSTER_POINT_TEST"), 2));
}

// The binned passes need full subgroups with arithmetic, ballot and shuffle (their walk per
// subgroup).
bool binnedAssignFor(const gpu::DeviceInfo& device) {
  if (!device.computeSubgroupShuffle) return false;
  if (envIs("MYRIAD_CLUSTER_ASSIGN", "atomic")) return false;
  if (envIs("MYRIAD_CLUSTER_ASSIGN", "binned")) return true;
  return !device.isCpu;
}

// The shading pass: each subgroup walking its tile's narrowed lists together
// (light_clustered_subgroup.comp) where compute shaders have the subgroup operations it needs,
// else each pixel on its own (light_clustered.comp; CPU devices too: on lavapipe the subgroup walk
// was slower). MYRIAD_CLUSTER_SHADE=pixel|subgroup overrides it (the benchmark compares the two;
// technique_tests holds them to the same light counts).
std::span<const uint32_t> shadeShaderFor(const gpu::DeviceInfo& device) {
  if (envIs("MYRIAD_CLUSTER_SHADE", "pixel") || !device.computeSubgroupShuffle) {
    return spirv::light_clustered_comp;
  }
  if (envIs("MYRIAD_CLUSTER_SHADE", "subgroup") || !device.isCpu) return spirv::light_clustered_subgroup_comp;
  return spirv::light_clustered_comp;
}

// CPU devices shade from the clusters' whole lists, without the tile's narrowing
// (light_clustered_whole.comp), while the longest list of the last frame reported had at most
// this many lights. On lavapipe (2 cores, built-in scene at 1280x720, myriad-bench, stop 17): 256
// lights, longest list 22, shade 83-85 ms whole against 114-115 narrowed; 1,024 lights, longest
// 78: 224 against 267; 4,096 lights, longest 297: 1,263 against 875.
constexpr uint32_t kWholeListsUpTo = 96;

// Whether the technique keeps the whole-list pass: CPU devices, unless MYRIAD_CLUSTER_SHADE
// names a pass (whole: always that one; pixel or subgroup: never).
enum class WholeLists { Never, WhenShort, Always };
WholeLists wholeListsFor(const gpu::DeviceInfo& device) {
  if (envIs("MYRIAD_CLUSTER_SHADE", "whole")) return WholeLists::Always;
  if (envIs("MYRIAD_CLUSTER_SHADE", "pixel") || envIs("MYRIAD_CLUSTER_SHADE", "subgroup")) {
    return WholeLists::Never;
  }
  return device.isCpu ? WholeLists::WhenShort : WholeLists::Never;
}

// The subgroup pass's walk (MYRIAD_SHADE_* bits of shared_types.h): MYRIAD_SHADE_DEFAULT, or the
// number in MYRIAD_CLUSTER_SHADE_VARIANT (a benchmark experiment, and technique_tests' way to run
// the walk before stop 16, 0). Read when the technique is made.
uint32_t shadeVariant() {
  if (!std::getenv("MYRIAD_CLUSTER_SHADE_VARIANT")) return MYRIAD_SHADE_DEFAULT;
  return static_cast<uint32_t>(envNumber("MYRIAD_CLUSTER_SHADE_VARIANT"));
}

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
               VkDeviceSize pairBytes)
      : grid(g), capacity(references), lightCapacity(lights), arena(context, kListBlockSize) {
    const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    ranges = arena.createBuffer(VkDeviceSize(grid.count()) * 8, storage, gpu::MemoryUse::DeviceLocal);
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
                                   VK_BUFFER_USAGE_TRANSFER_DST_BIT,
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
  bool cursorsInactive = false;  // the cursors hold MYRIAD_CLUSTER_INACTIVE (after the first frame)
};

class Clustered final : public LightingTechnique {
 public:
  explicit Clustered(const TechniqueSetup& setup)
      : context_(setup.context), pipelines_(setup.context.device),
        shade_(setup.context.device, setup.pipelines.layout, shadeShaderFor(setup.context.info),
               shadeVariant()),
        wholeLists_(wholeListsFor(setup.context.info)),
        set_(setup.context, setup.pipelines), counters_(setup.context),
        binnedAssign_(binnedAssignFor(setup.context.info)),
        animateInCount_(binnedAssign_ && !separateAnimation()),
        markInGBuffer_(markInGBuffer()),
        pointTest_(pointTest(setup.context.info)) {
    requireWorkgroup(setup.context, MYRIAD_SCAN_GROUP, MYRIAD_SCAN_GROUP);
    requireWorkgroup(setup.context, MYRIAD_ASSIGN_BIN_GROUP, MYRIAD_ASSIGN_BIN_GROUP);
    VkDevice device = setup.context.device;
    VkPipelineLayout layout = setup.pipelines.layout;
    if (wholeLists_ != WholeLists::Never) {
      shadeWhole_ = std::make_unique<FeaturePipelines>(device, layout,
                                                       spirv::light_clustered_whole_comp);
    }
    {
      // cluster_mark.comp: kNumber (constant 0), kPointTest (7: no bounds gathered when 0).
      const VkSpecializationMapEntry entries[] = {{0, 0, sizeof(VkBool32)},
                                                  {7, sizeof(VkBool32), sizeof(uint32_t)}};
      for (VkBool32 number : {VK_FALSE, VK_TRUE}) {
        const uint32_t values[] = {number, pointTest_};
        VkSpecializationInfo spec{2, entries, sizeof(values), values};
        (number ? number_ : mark_) = pipelines_.add(
            gpu::createComputePipeline(device, layout, spirv::cluster_mark_comp, &spec));
      }
    }
    scan_ = pipelines_.add(gpu::createComputePipeline(device, layout, spirv::cluster_scan_comp));
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
      markBlend_ = pipelines_.add(gpu::createGraphicsPipeline(device, layout, d));
    }
    // cluster_assign.comp counts (kAssign = false) or fills the lists (true): one source, so both
    // passes run the identical overlap test.
    // kLarge (constant 1) picks the per-light or the per-large-light (workgroup) variant.
    // kPointTest (7) the boxes a light is tested against (pointTest()).
    const VkSpecializationMapEntry entries[] = {{0, 0, sizeof(VkBool32)},
                                                {1, sizeof(VkBool32), sizeof(VkBool32)},
                                                {7, 2 * sizeof(VkBool32), sizeof(uint32_t)}};
    for (VkBool32 assign : {VK_FALSE, VK_TRUE}) {
      for (VkBool32 large : {VK_FALSE, VK_TRUE}) {
        const uint32_t values[] = {assign, large, pointTest_};
        VkSpecializationInfo spec{3, entries, sizeof(values), values};
        VkPipeline& target = assign ? (large ? assignLarge_ : assign_) : (large ? countLarge_ : count_);
        target = pipelines_.add(
            gpu::createComputePipeline(device, layout, spirv::cluster_assign_comp, &spec));
      }
      // cluster_assign_binned.comp: kAssign (constant 0), its table's bins (2), kAnimate (3),
      // kMostClusters (5), the workgroup's size (6), kPointTest (7); each a 4-byte word.
      const VkSpecializationMapEntry binnedEntries[] = {
          {0, 0, 4}, {2, 4, 4}, {3, 8, 4}, {5, 12, 4}, {6, 16, 4}, {7, 20, 4}};
      for (VkBool32 animate : {VK_FALSE, VK_TRUE}) {
        if (assign && animate) continue;
        const uint32_t binnedValues[] = {assign, assignBins(), animate, mostClustersPerLight(),
                                         binnedGroupSize(setup.context.info),
                                         pointTest_};
        VkSpecializationInfo binnedSpec{6, binnedEntries, sizeof(binnedValues), binnedValues};
        (assign ? assignBinned_ : animate ? countBinnedAnimated_ : countBinned_) = pipelines_.add(
            gpu::createComputePipeline(device, layout, spirv::cluster_assign_binned_comp, &binnedSpec));
      }
    }
  }

  // The lists follow the output size, the light count and what they grew to; they are rebuilt
  // only when those change. Sessions' scenes take turns: lists that hold what this frame wants,
  // without more than twice the waste, stay, so frames of a 1,000-light and a 100,000-light scene
  // in turn do not reallocate them every frame.
  void prepare(VkExtent2D extent, uint32_t lightCount) override {
    const uint64_t mostReferences = maxListBytes() / sizeof(uint32_t);
    const ClusterGrid grid = clusterGrid(extent);
    uint32_t capacity = initialCapacity(grid, lightCount, mostReferences);
    if (listStartCapacity_ > 0) capacity = listStartCapacity_;
    capacity = static_cast<uint32_t>(
        std::min<uint64_t>(std::max(capacity, grownListCapacity_), mostReferences));
    const bool keep = lists_ && lists_->grid == grid && lists_->capacity >= capacity &&
                      lists_->capacity <= 2 * uint64_t(capacity) &&
                      lists_->capacity <= mostReferences && lists_->lightCapacity >= lightCount;
    if (keep) return;
    lists_.reset();
    lists_ = std::make_unique<ClusterLists>(context_, grid, capacity, lightCount, pairBytes(lightCount));
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
    u.written.z = !markInGBuffer_ ? 0u
                  : MYRIAD_RESOLVE_MARKS | (pointTest_ != 0 ? MYRIAD_RESOLVE_BOUNDS : 0u);
  }

  // On GPUs the counting pass moves the lights as it walks them: one pass over the lights fewer.
  bool animatesLights() const override { return animateInCount_; }

  // Reads the G-buffer and lights; builds the cluster lists (mark, count, scan, assign), then
  // writes HDR and light counts (GENERAL layout) and the counters.
  VkImageLayout record(const LightingPass& pass) override {
    VkCommandBuffer cmd = pass.cmd;
    const FrameTargets& t = pass.targets;
    // Two timed parts: "assign" (steps 1-4, building the lists) and "shade" (step 5).
    pass.timer.beginPass(cmd, "assign");
    set_.bind(cmd);
    // Every cluster starts inactive: the last frame's scan left the cursors so, and new lists get
    // it once here. The mark pass empties the counters and the large-light queue.
    VkPipelineStageFlags2 before = 0;
    if (!lists_->cursorsInactive) {
      // Cursors, counts and numbers MYRIAD_CLUSTER_INACTIVE, no cluster numbered yet.
      const VkDeviceSize numbered = VkDeviceSize(lists_->grid.count()) * 16;
      vkCmdFillBuffer(cmd, lists_->cursors.buffer, 0, numbered, MYRIAD_CLUSTER_INACTIVE);
      vkCmdFillBuffer(cmd, lists_->cursors.buffer, numbered, 4, 0);
      lists_->cursorsInactive = true;
      before = kFillStage;
    }
    // Moving the lights here: their readers before in the frame (none today) finish first; the
    // last frame's are behind the renderer's barrier before the lighting.
    const bool animate = pass.animateLights && pass.scene.lightCount > 0;
    const VkPipelineStageFlags2 lightReaders = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                                               VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kComputeStage;
    if (animate) before |= lightReaders;
    if (before != 0) {
      gpu::memoryBarrier(cmd, before,
                         (before & kFillStage) != 0 ? VK_ACCESS_2_TRANSFER_WRITE_BIT : VK_ACCESS_2_NONE,
                         kComputeStage, kStorageReadWrite);
    }

    // 1. Mark clusters holding visible geometry (the compute G-buffer's resolve did, or a pass
    // over the pixels here), then number them (a cluster an invocation).
    if (assignSteps()) pass.timer.beginPass(cmd, "assign-mark");
    if (!(pass.computeGBuffer && markInGBuffer_)) {
      dispatchPixels(cmd, mark_, t.extent, MYRIAD_PIXEL_GROUP);
      gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, number_);
    vkCmdDispatch(cmd, groupCount(lists_->grid.count(), MYRIAD_PIXEL_GROUP * MYRIAD_PIXEL_GROUP), 1, 1);
    gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
    // 1b. And those of alpha-blended surfaces in front of it (or over the background).
    if (markBlend_ != VK_NULL_HANDLE && hasBlendDraws(pass.scene)) markBlendClusters(cmd, pass);
    uint32_t lightGroups = groupCount(pass.scene.lightCount, MYRIAD_LIGHTS_PER_GROUP);
    if (lightGroups > 0) {
      // 2. Count each active cluster's lights: small lights a thread each, queueing the large
      // ones, then the queue a workgroup per light (an indirect dispatch of the queue's length).
      if (assignSteps()) pass.timer.beginPass(cmd, "assign-count");
      dispatchSmallLights(cmd, pass.scene.lightCount, count_, animate ? countBinnedAnimated_ : countBinned_);
      // With the lights moved, their later readers too (markers' vertex and the blend pass's
      // fragment shaders).
      gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite,
                         kComputeStage | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT |
                             (animate ? lightReaders : 0),
                         kStorageReadWrite | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
      if (assignSteps()) pass.timer.beginPass(cmd, "assign-count-large");
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, countLarge_);
      vkCmdDispatchIndirect(cmd, lists_->large.buffer, 0);
      gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
    }
    // 3. Prefix sum: list offsets, capacity cuts, counters.
    if (assignSteps()) pass.timer.beginPass(cmd, "assign-scan");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scan_);
    vkCmdDispatch(cmd, groupCount(lists_->grid.count(), MYRIAD_SCAN_GROUP * MYRIAD_SCAN_CLUSTERS_PER_THREAD),
                  1, 1);
    gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage, kStorageReadWrite);
    if (lightGroups > 0) {
      // 4. Fill the lists: the same split, the queue kept from step 2.
      if (assignSteps()) pass.timer.beginPass(cmd, "assign-fill");
      dispatchSmallLights(cmd, pass.scene.lightCount, assign_, assignBinned_);
      // The small-light pass does not write the queue, and its list slots are not the large
      // lights', but it holds both writable: order it before the indirect read and the large
      // lights' pass all the same (the synchronization layer's rule).
      gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite,
                         kComputeStage | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                         kStorageReadWrite | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
      if (assignSteps()) pass.timer.beginPass(cmd, "assign-fill-large");
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, assignLarge_);
      vkCmdDispatchIndirect(cmd, lists_->large.buffer, 0);
      gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, kComputeStage,
                         VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    }
    // 5. Shade every pixel from its cluster's list, narrowed per tile (or whole: kWholeListsUpTo).
    pass.timer.beginPass(cmd, "shade");
    prepareLightingTargets(cmd, t);
    const bool whole = wholeLists_ == WholeLists::Always ||
                       (wholeLists_ == WholeLists::WhenShort &&
                        lastLongestList_.load(std::memory_order_relaxed) <= kWholeListsUpTo);
    FeaturePipelines& shade = whole ? *shadeWhole_ : shade_;
    dispatchPixels(cmd, shade.get(pass.shadingFeatures), t.extent, MYRIAD_CLUSTER_SHADE_TILE);
    counters_.makeHostVisible(cmd);
    return VK_IMAGE_LAYOUT_GENERAL;
  }

  bool bindForwardLights(VkCommandBuffer cmd) const override {
    if (markBlend_ == VK_NULL_HANDLE) return false;
    set_.bindGraphics(cmd);
    return true;
  }

  const gpu::Buffer* counters() const override { return &counters_.stats; }
  void report(CullingReport& report, const void* counters) const override {
    CullingCounters::read(counters, report);
    lastLongestList_.store(report.mostLightsInList, std::memory_order_relaxed);
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
  // The small lights' count or fill pass: per light (`perLight`, one thread each) or per
  // workgroup run (`binned`), as binnedAssign_ says.
  void dispatchSmallLights(VkCommandBuffer cmd, uint32_t lightCount, VkPipeline perLight,
                           VkPipeline binned) const {
    if (binnedAssign_) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, binned);
      vkCmdDispatch(cmd, binnedGroups(lightCount), 1, 1);
    } else {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, perLight);
      vkCmdDispatch(cmd, groupCount(lightCount, MYRIAD_LIGHTS_PER_GROUP), 1, 1);
    }
  }

  // The blended draws, depth-tested against the G-buffer without writing it, write 0 (active) into
  // the cursor of each fragment's cluster (cluster_mark_blend.frag).
  void markBlendClusters(VkCommandBuffer cmd, const LightingPass& pass) const {
    const VkPipelineStageFlags2 fragment = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    gpu::memoryBarrier(cmd, kComputeStage, kStorageWrite, fragment, kStorageReadWrite);
    VkRenderingAttachmentInfo depth = readOnlyDepth(pass.targets.depth);
    beginRendering(cmd, pass.targets.extent, {}, &depth);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, markBlend_);
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

  // The workgroups of the binned passes for `lightCount` lights (at least one).
  // MYRIAD_ASSIGN_GROUPS (64 to 4096) overrides the most (the multiprocessors or
  // kBinnedAssignGroups) and MYRIAD_ASSIGN_GROUP_LIGHTS (16 to 65536) kBinnedGroupLights:
  // benchmark experiments.
  uint32_t binnedGroups(uint32_t lightCount) const {
    static const uint64_t asked = envNumber("MYRIAD_ASSIGN_GROUPS");
    const uint32_t multiprocessors = context_.info.multiprocessors;
    const uint32_t most = asked >= 64 && asked <= 4096 ? uint32_t(asked)
                          : multiprocessors > 0     ? multiprocessors
                                                    : kBinnedAssignGroups;
    static const uint32_t groupLights = [] {
      const uint64_t n = envNumber("MYRIAD_ASSIGN_GROUP_LIGHTS");
      return n >= 16 && n <= 65536 ? uint32_t(n) : kBinnedGroupLights;
    }();
    return std::clamp(groupCount(lightCount, groupLights), 1u, most);
  }

  // The pair buffer of cluster_assign_binned.comp for `lightCount` lights: a count and a table per
  // workgroup, then pairSlotsPerLight() slots per light (within the device's storage range). The
  // lists are kept for fewer lights: the passes then run fewer groups, whose regions are larger.
  VkDeviceSize pairBytes(uint32_t lightCount) const {
    if (!binnedAssign_) return 4;
    const uint64_t groups = binnedGroups(lightCount);
    const uint64_t tables = groups * (1 + uint64_t(assignBins())) * 4;
    const uint64_t slotBytes = kPairWordsPerSlot * 4;
    // The floor only with the default slots: an override is there to fill the regions.
    const uint64_t floor = envNumber("MYRIAD_ASSIGN_PAIR_SLOTS") == 0 ? kMinimumPairSlots : 1;
    const uint64_t wanted = std::max(uint64_t(lightCount) * pairSlotsPerLight(), floor) * slotBytes;
    const uint64_t room = context_.info.maxStorageBufferRange - tables;
    return tables + std::min(wanted, room / slotBytes * slotBytes);
  }

  gpu::Context& context_;
  PipelineList pipelines_;
  VkPipeline mark_ = VK_NULL_HANDLE;    // cluster_mark.comp's pixel pass
  VkPipeline number_ = VK_NULL_HANDLE;  // its numbering pass (kNumber)
  VkPipeline count_ = VK_NULL_HANDLE;
  VkPipeline scan_ = VK_NULL_HANDLE;
  VkPipeline assign_ = VK_NULL_HANDLE;
  VkPipeline countLarge_ = VK_NULL_HANDLE;   // the queued large lights, a workgroup each
  VkPipeline assignLarge_ = VK_NULL_HANDLE;
  VkPipeline countBinned_ = VK_NULL_HANDLE;  // cluster_assign_binned.comp
  VkPipeline countBinnedAnimated_ = VK_NULL_HANDLE;  // the same, moving the lights (kAnimate)
  VkPipeline assignBinned_ = VK_NULL_HANDLE;
  FeaturePipelines shade_;  // specialised per frame (render/shading_features.h)
  WholeLists wholeLists_;
  std::unique_ptr<FeaturePipelines> shadeWhole_;  // light_clustered_whole.comp, unless Never
  // The longest list of the last frame reported (any scene; unknown at first): the whole-list
  // pass is chosen from it, and a choice made from another scene's or an older frame's lists
  // costs time only (both passes make the same image).
  mutable std::atomic<uint32_t> lastLongestList_{UINT32_MAX};
  VkPipeline markBlend_ = VK_NULL_HANDLE;  // null without fragmentStoresAndAtomics
  CullingSet set_;
  CullingCounters counters_;
  bool binnedAssign_;  // small lights by cluster_assign_binned.comp (else cluster_assign.comp)
  bool animateInCount_;  // animatesLights()
  bool markInGBuffer_;   // the compute G-buffer's resolve marks the clusters (markInGBuffer())
  uint32_t pointTest_;   // the boxes lights are tested against (pointTest(); bounds unless 0)
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
