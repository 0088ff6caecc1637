// The renderer's tuning knobs, in one place (issue 37): every switch a benchmark or a test may
// turn, named, typed and documented here, set through one interface (`--tune key=value`, on
// myriad-server and the bench binaries: applyTune()), carried into the renderer's construction
// (Renderer(context, tuning)), and resolved once per device (resolveTuning(): the defaults that
// depend on the device's properties). Nothing in render/, gpu/ or shaders/ reads the environment
// (CTest `no_getenv_in_render`).
//
// The defaults are what the product runs; each knob says why, and which measurement chose it
// (docs/performance.md, bench/history/). No Vulkan here: service/ parses --tune with it.
#pragma once

#include <charconv>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace myriad::gpu {
struct DeviceInfo;
}

namespace myriad::render {

// How the clustered technique counts its small lights into the clusters (techniques/clustered.cpp).
enum class AssignPath : uint8_t {
  Auto,    // resolved: Binned on GPUs with the subgroup operations it needs, PerPair elsewhere
  PerPair, // one global atomic per light-cluster pair (cluster_assign.comp): cheap on CPUs
  Binned,  // per workgroup in shared memory (cluster_assign_binned.comp): GPUs, where the busiest
           // cluster's per-pair atomics were serialised
};

// When the stochastic shadows' BVH (render/bvh.h) is built again (render/stochastic_shadows.cpp).
enum class BvhUpdate : uint8_t {
  Auto,     // rebuilt for a new scene or triangle count, refitted when its geometry moved
  Rebuild,  // rebuilt every frame (the benchmark times the whole build)
  Refit,    // refitted every frame (the benchmark times the refit)
};

// Which pass shades the clustered technique's pixels (techniques/clustered.cpp).
enum class ShadePass : uint8_t {
  Auto,            // resolved: Subgroup on GPUs with subgroup shuffle, WholeWhenShort on CPUs
  Pixel,           // each pixel walks its tile's narrowed lists (light_clustered.comp)
  Subgroup,        // each subgroup walks them together (light_clustered_subgroup.comp)
  Whole,           // each pixel walks its cluster's whole list (light_clustered_whole.comp)
  WholeWhenShort,  // Whole while the last frame's longest list is short, else Pixel (CPU devices:
                   // on lavapipe the whole lists were faster up to about 96 lights a list)
};

struct Tuning {
  // --- The cluster grid (render/cluster_grid.h) ---
  // cluster-tile: the screen tiles' size in pixels, 16, 32 or 64. 64 (MYRIAD_CLUSTER_TILE_SIZE);
  // smaller tiles shorten the lists and add clusters (a benchmark experiment: the shading pass's
  // 16-pixel tiles divide each).
  uint32_t clusterTile = 64;
  // cluster-slices: exponential depth slices between near and far, 16 to 128. 32
  // (MYRIAD_CLUSTER_SLICES); thinner slices shorten the lists and add clusters.
  uint32_t clusterSlices = 32;

  // --- The clustered technique's light assignment (techniques/clustered.cpp) ---
  // assign: auto, atomic (per pair) or binned (technique_tests holds the two to the same lists).
  AssignPath assign = AssignPath::Auto;
  // assign-pair-slots: pair slots the binned passes reserve per light, 1 to 64. Unset: 8, and the
  // pair buffer holds at least 2^20 slots. Fewer send lights down the full region's path (slower,
  // never wrong): a benchmark experiment, and a test's way to take that path.
  std::optional<uint32_t> assignPairSlots;
  // assign-bins: the binned passes' shared-table bins, 256 to 4096. 4096 (MYRIAD_ASSIGN_BINS).
  uint32_t assignBins = 4096;
  // assign-group-size: the binned passes' workgroup size, 256, 512 or 1024; resolved: halved
  // while the device runs no groups that large. 1024: on the H200, a million lights at 1080p,
  // assign took 0.239 ms at 256, 0.144 at 512, 0.122 at 1024 (issue 16, stop 17).
  uint32_t assignGroupSize = 1024;
  // assign-groups: the most workgroups the binned passes run, 64 to 4096. Unset, resolved: one per
  // multiprocessor where the driver says how many, else 128. The pass takes as long as the
  // busiest multiprocessor: on the H200 (132 SMs) 128 groups beat 64 to 2,048 with a million
  // lights at 1080p and at 4K (issue 16, stop 16).
  std::optional<uint32_t> assignGroups;
  // assign-group-lights: the fewest lights a binned workgroup takes, 16 to 65536. 64: 10,000
  // lights get 128 groups, not 40 (H200: assign 0.081 -> 0.064 ms at 1080p, stop 16).
  uint32_t assignGroupLights = 64;
  // assign-most-clusters: lights whose box holds more clusters than this go to the large-light
  // passes (a workgroup each), 1 to 65536. 64 (MYRIAD_LARGE_LIGHT_CLUSTERS).
  uint32_t assignMostClusters = 64;
  // assign-steps: time the assignment's steps apart ("assign-mark", "-count", "-count-large",
  // "-scan", "-fill", "-fill-large"; "assign" then holds the clears only). A diagnostic: the
  // extra timestamps wait for the work before them. Off.
  bool assignSteps = false;
  // animate-separate: the binned counting pass leaves moving the lights to the renderer's animate
  // pass (light_animate.comp), as the per-pair path always does. Off (a benchmark comparison).
  bool animateSeparate = false;
  // mark-in-gbuffer: the compute G-buffer's resolve marks the clusters holding geometry where it
  // runs (it reads every pixel's depth anyway); off keeps the technique's own pixel pass (a
  // benchmark comparison, and technique_tests' second renderer). On.
  bool markInGBuffer = true;
  // point-test: the boxes a light is tested against (cluster_assign.glsl's kPointTest): 2 the
  // bounds of a cluster's surface points, 1 those and the cluster's view box, 0 the view box only.
  // Unset, resolved: 2 on GPUs, 0 on CPU devices (on llvmpipe gathering the bounds took a 1280x720
  // still's assign from 8-12 ms to 38-46, more than the shorter lists save). Same image either way.
  std::optional<uint32_t> pointTest;

  // --- The clustered technique's shading ---
  // shade: auto, pixel, subgroup or whole (technique_tests holds them to the same light counts).
  ShadePass shade = ShadePass::Auto;
  // shade-variant: the subgroup pass's walk, MYRIAD_SHADE_* bits (shared_types.h), decimal or 0x
  // hex. 0x7B (MYRIAD_SHADE_DEFAULT); 0 is the walk before issue 16's stop 16, and the DIAG bits
  // are measurements that make wrong images.
  uint32_t shadeVariant = 0x7B;

  // --- Stochastic local shadows (render/stochastic_shadows.h) ---
  // bvh-update: auto, rebuild or refit (every frame: what the benchmark times). Auto.
  BvhUpdate bvhUpdate = BvhUpdate::Auto;
  // stochastic-candidates: M, the candidates a pixel resamples its shadow ray's light from, 1 to
  // 256: each light of a cluster list of L is one with probability min(1, M / L), so a list no
  // longer than M is taken whole (every light weighed by its unshadowed light: the noise is the
  // shadows' alone). 32: the built-in scene's lists are shorter; a million lights' are thinned.
  uint32_t stochasticCandidates = 32;

  // --- The sun's cascades (render/shadows.h) ---
  // sun-scroll: after a camera move, a cascade's map is its old one shifted by whole texels
  // (ShadowMaps::scrollSun: copied, and only the uncovered strips drawn) instead of drawn whole.
  // Unset, resolved: on for CPU devices, off on GPUs. lavapipe, 320x180, 10,000 lights, 2048
  // maps, an orbiting camera: "shadow" 56 -> 14 ms; H100 1280x720: 2.34 ms drawn whole, 2.47 ms
  // scrolled (the depth copies cost more there than the redraw: docs/performance.md G5).
  std::optional<bool> sunScroll;

  // --- The device (gpu/context.cpp) ---
  // pipeline-stats: compute pipelines print the driver's statistics (registers, local and shared
  // memory) where the device has VK_KHR_pipeline_executable_properties. A diagnostic. Off.
  bool pipelineStatistics = false;

  bool operator==(const Tuning&) const = default;
};

// A bad --tune: the message is one sentence naming the key and what it takes.
class TuningError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The knobs resolved for `device` (gpu/device_info.h): Auto and unset values replaced by the
// device's defaults, requests the device cannot run brought within it. Renderer() calls it once.
Tuning resolveTuning(const Tuning& asked, const gpu::DeviceInfo& device);

// What `--help` lists: one line per key, its values and default.
inline const char* tuningKeys() {
  return "    cluster-tile=16|32|64            cluster tiles' size in pixels (64)\n"
         "    cluster-slices=16..128           cluster depth slices (32)\n"
         "    assign=auto|atomic|binned        small lights counted per pair or per workgroup\n"
         "                                     (auto: binned on GPUs, atomic on CPU devices)\n"
         "    assign-pair-slots=1..64          binned pair slots per light (8, at least 2^20 in all)\n"
         "    assign-bins=256..4096            binned shared-table bins (4096)\n"
         "    assign-group-size=256|512|1024   binned workgroup size (1024, within the device)\n"
         "    assign-groups=64..4096           most binned workgroups (the multiprocessors, or 128)\n"
         "    assign-group-lights=16..65536    fewest lights a binned workgroup takes (64)\n"
         "    assign-most-clusters=1..65536    clusters past which a light is large (64)\n"
         "    assign-steps=on|off              time the assignment's steps apart (off)\n"
         "    animate-separate=on|off          lights moved by their own pass, not the count (off)\n"
         "    mark-in-gbuffer=on|off           compute G-buffer marks the clusters (on)\n"
         "    point-test=0|1|2                 light test boxes (2 on GPUs, 0 on CPU devices)\n"
         "    shade=auto|pixel|subgroup|whole  clustered shading pass (auto: by device)\n"
         "    shade-variant=N                  subgroup walk bits, MYRIAD_SHADE_* (0x7B)\n"
         "    bvh-update=auto|rebuild|refit    stochastic shadows' BVH: when it is built (auto)\n"
         "    stochastic-candidates=1..256     lights a pixel resamples its shadow ray's from (32)\n"
         "    sun-scroll=on|off                moved cascades shifted, not redrawn (CPU devices)\n"
         "    pipeline-stats=on|off            print compute pipelines' driver statistics (off)\n";
}

namespace tuning_detail {

inline bool parseNumber(std::string_view text, uint32_t& value) {
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    text.remove_prefix(2);
    base = 16;
  }
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
  return !text.empty() && ec == std::errc() && ptr == end;
}

[[noreturn]] inline void refuse(std::string_view key, std::string_view expected,
                                std::string_view value) {
  throw TuningError("--tune " + std::string(key) + " expects " + std::string(expected) +
                    ", not \"" + std::string(value) + "\".");
}

inline uint32_t number(std::string_view key, std::string_view value, uint32_t least,
                       uint32_t most) {
  uint32_t n = 0;
  if (!parseNumber(value, n) || n < least || n > most) {
    refuse(key, "a number from " + std::to_string(least) + " to " + std::to_string(most), value);
  }
  return n;
}

inline bool onOff(std::string_view key, std::string_view value) {
  if (value == "on" || value == "1" || value == "true") return true;
  if (value == "off" || value == "0" || value == "false") return false;
  refuse(key, "on or off", value);
}

}  // namespace tuning_detail

// Applies one `key=value` (the argument of a --tune flag) to `tuning`. Throws TuningError naming
// the key for an unknown key, a missing '=' or a value the key does not take.
inline void applyTune(Tuning& tuning, std::string_view keyValue) {
  using namespace tuning_detail;
  const size_t equals = keyValue.find('=');
  if (equals == std::string_view::npos || equals == 0) {
    throw TuningError("--tune expects key=value, not \"" + std::string(keyValue) +
                      "\" (see --help for the keys).");
  }
  const std::string_view key = keyValue.substr(0, equals);
  const std::string_view value = keyValue.substr(equals + 1);
  if (key == "cluster-tile") {
    if (value != "16" && value != "32" && value != "64") refuse(key, "16, 32 or 64", value);
    tuning.clusterTile = number(key, value, 16, 64);
  } else if (key == "cluster-slices") {
    tuning.clusterSlices = number(key, value, 16, 128);
  } else if (key == "assign") {
    if (value == "auto") tuning.assign = AssignPath::Auto;
    else if (value == "per-pair" || value == "atomic") tuning.assign = AssignPath::PerPair;
    else if (value == "binned") tuning.assign = AssignPath::Binned;
    else refuse(key, "auto, atomic or binned", value);
  } else if (key == "assign-pair-slots") {
    tuning.assignPairSlots = number(key, value, 1, 64);
  } else if (key == "assign-bins") {
    tuning.assignBins = number(key, value, 256, 4096);
  } else if (key == "assign-group-size") {
    if (value != "256" && value != "512" && value != "1024") refuse(key, "256, 512 or 1024", value);
    tuning.assignGroupSize = number(key, value, 256, 1024);
  } else if (key == "assign-groups") {
    tuning.assignGroups = number(key, value, 64, 4096);
  } else if (key == "assign-group-lights") {
    tuning.assignGroupLights = number(key, value, 16, 65536);
  } else if (key == "assign-most-clusters") {
    tuning.assignMostClusters = number(key, value, 1, 65536);
  } else if (key == "assign-steps") {
    tuning.assignSteps = onOff(key, value);
  } else if (key == "animate-separate") {
    tuning.animateSeparate = onOff(key, value);
  } else if (key == "mark-in-gbuffer") {
    tuning.markInGBuffer = onOff(key, value);
  } else if (key == "point-test") {
    tuning.pointTest = number(key, value, 0, 2);
  } else if (key == "shade") {
    if (value == "auto") tuning.shade = ShadePass::Auto;
    else if (value == "pixel") tuning.shade = ShadePass::Pixel;
    else if (value == "subgroup") tuning.shade = ShadePass::Subgroup;
    else if (value == "whole") tuning.shade = ShadePass::Whole;
    else refuse(key, "auto, pixel, subgroup or whole", value);
  } else if (key == "shade-variant") {
    tuning.shadeVariant = number(key, value, 0, UINT32_MAX);
  } else if (key == "bvh-update") {
    if (value == "auto") tuning.bvhUpdate = BvhUpdate::Auto;
    else if (value == "rebuild") tuning.bvhUpdate = BvhUpdate::Rebuild;
    else if (value == "refit") tuning.bvhUpdate = BvhUpdate::Refit;
    else refuse(key, "auto, rebuild or refit", value);
  } else if (key == "stochastic-candidates") {
    tuning.stochasticCandidates = number(key, value, 1, 256);
  } else if (key == "sun-scroll") {
    tuning.sunScroll = onOff(key, value);
  } else if (key == "pipeline-stats") {
    tuning.pipelineStatistics = onOff(key, value);
  } else {
    throw TuningError("--tune: unknown key \"" + std::string(key) +
                      "\" (see --help for the keys).");
  }
}

}  // namespace myriad::render
