// The clustered technique's lists and pipelines (techniques/clustered.cpp is the technique):
// the sizes its lists start from and grow by, the buffers of a grid (ClusterLists), and the
// pipelines made once and shared by its whole frames' and split frame's instances
// (ClusteredPipelines, made in clustered_pipelines.cpp). Internal to those two files.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "render/cluster_grid.h"
#include "render/shading_features.h"
#include "render/techniques/compute_lighting.h"
#include "render/techniques/technique.h"
#include "shared_types.h"

namespace myriad::render::clustered {

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
inline uint64_t pairSlotsPerLight(const Tuning& tuning) {
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
std::span<const uint32_t> shadeShaderFor(const Tuning& tuning, const gpu::DeviceInfo& device);

// CPU devices shade from the clusters' whole lists, without the tile's narrowing
// (light_clustered_whole.comp), while the longest list of the last frame reported had at most
// this many lights. On lavapipe (2 cores, built-in scene at 1280x720, myriad-bench, stop 17): 256
// lights, longest list 22, shade 83-85 ms whole against 114-115 narrowed; 1,024 lights, longest
// 78: 224 against 267; 4,096 lights, longest 297: 1,263 against 875.
constexpr uint32_t kWholeListsUpTo = 96;

// Whether the technique keeps the whole-list pass: CPU devices (ShadePass::WholeWhenShort),
// unless --tune shade names a pass (whole: always that one; pixel or subgroup: never).
enum class WholeLists { Never, WhenShort, Always };
WholeLists wholeListsFor(const Tuning& tuning);

// The subgroup pass's walk (MYRIAD_SHADE_* bits of shared_types.h): tuning.shadeVariant,
// MYRIAD_SHADE_DEFAULT unless --tune shade-variant asks for another (a benchmark experiment, and
// technique_tests' way to run the walk before stop 16, 0).

// The capacity a grid of `grid` with `lightCount` lights starts with, at most `mostReferences`.
uint32_t initialCapacity(const ClusterGrid& grid, uint32_t lightCount, uint64_t mostReferences);

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
  explicit ClusteredPipelines(const TechniqueSetup& setup);

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

}  // namespace myriad::render::clustered
