// A lighting technique: how one frame's local lights get into the HDR and light-count targets.
// Each technique is one file in this directory holding its pipelines, its buffers, its commands
// and its culling report; the frame function (frame_recording.cpp, split_frame.cpp) calls it
// through this interface and knows none of them by name. registry.cpp lists them.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "render/frame.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "render/tuning.h"
#include "shared_types.h"

namespace myriad::render {

class StochasticShadows;  // render/stochastic_shadows.h

// What a technique is built from: the device, the frame's shared pipeline layout (sets 0-2;
// set 2, light culling, is the technique's to fill: see compute_lighting.h), and the knobs
// resolved for the device (render/tuning.h).
struct TechniqueSetup {
  gpu::Context& context;
  const Pipelines& pipelines;
  const Tuning& tuning;
};

// One frame's lighting: where to record, the timer for its passes, what it reads and writes.
struct LightingPass {
  VkCommandBuffer cmd;
  gpu::PassTimer& timer;
  const FrameTargets& targets;
  const SceneBuffers& scene;
  // What the frame's shading may need (MYRIAD_FEATURE_*, render/shading_features.h): the compute
  // techniques shade with a pipeline specialised to it.
  uint32_t shadingFeatures = MYRIAD_FEATURES_ALL;
  // The lights move this frame and the technique said it moves them (animatesLights()): its
  // passes write each light's position (light_orbit.glsl) before anything reads it.
  bool animateLights = false;
  // The G-buffer was made in compute (render/visibility.h): its resolve pass marked the clusters
  // holding geometry in targets.clusterMarks where the uniforms asked (FrameUniforms.written.z).
  bool computeGBuffer = false;
  // Recorded in parts (Renderer::SplitFrame): what the renderer reads between them is made
  // host-readable where it is complete (listsBuiltAfter).
  bool split = false;
  // Stochastic local shadows (render/stochastic_shadows.h): the technique's shading step binds
  // this pass instead of its own (the clustered technique; null: shade as usual).
  const StochasticShadows* stochastic = nullptr;
};

class LightingTechnique {
 public:
  virtual ~LightingTechnique() = default;

  // Before the frame is recorded (nothing is in flight): fit the technique's buffers to an output
  // of `extent` with `lightCount` lights. May throw gpu::VulkanError (out of memory).
  virtual void prepare(VkExtent2D extent, uint32_t lightCount) {
    (void)extent;
    (void)lightCount;
  }
  // Its part of the frame's uniforms (the renderer fills the rest before calling this).
  virtual void writeUniforms(FrameUniforms& uniforms) const { (void)uniforms; }

  // Records the lighting, each pass after a timer.beginPass with its name. Reads the G-buffer
  // (READ_ONLY_OPTIMAL, as the gbuffer pass leaves it) and the lights (sets 0 and 1 are bound for
  // graphics and compute); writes every pixel of hdr and lightCount, whose previous contents are
  // discarded, and leaves both in the returned layout: GENERAL after compute storage writes,
  // COLOR_ATTACHMENT_OPTIMAL after raster writes. Anything the host reads afterwards (report(), counters())
  // gets its barrier here. Every step of steps() whole, in order.
  VkImageLayout record(const LightingPass& pass) {
    const std::vector<Step> all = steps(pass);
    for (uint32_t i = 0; i < all.size(); ++i) {
      if (all[i].units == 0) continue;
      pass.timer.beginPass(pass.cmd, all[i].name);
      recordStep(pass, i, 0, all[i].units);
    }
    return lightingLayout();
  }

  // Whether record() moves animated lights itself (LightingPass::animateLights), in a pass that
  // reads the lights anyway; false (the default): the renderer's animate pass moves them first.
  virtual bool animatesLights() const { return false; }

  // Light lists for the forward pass of alpha-blended surfaces (recordBlendPass): binds them (set
  // 2, MYRIAD_BINDING_CLUSTER_RANGES and _LIGHTS, covering every cluster a blended fragment lies
  // in) at the graphics bind point and returns true; false (the default): the forward pass tests
  // every light. Called after record().
  virtual bool bindForwardLights(VkCommandBuffer cmd) const {
    (void)cmd;
    return false;
  }

  // The lighting in parts (Renderer::SplitFrame): a fixed sequence of steps, each of `units`
  // (lights, or workgroups of pixels) that may be recorded in ranges, each range in a submission
  // of its own with other frames' work between them. A step's ranges in order make exactly the
  // commands of the step recorded whole, and record() is every step whole, in order, so a frame
  // split into parts is the frame recorded in one submission.
  struct Step {
    const char* name;  // the timed pass (its ranges add up under one name)
    uint32_t units;    // 0: nothing to record this frame; 1: recorded whole
    // The units cost about the same (lights, workgroups of a pass over every pixel alike): the
    // ranges may grow fast from the first ones measured. False: they differ in ways nobody
    // measured (tiles of sky and of long light lists): ranges grow slowly, and a costly unit
    // keeps the estimate up for several parts.
    bool unitsAlike = true;
  };
  virtual std::vector<Step> steps(const LightingPass& pass) const = 0;
  // Records units [first, first + count) of `step`. `pass.cmd` may be a command buffer of its
  // own (sets 0 and 1 bound, everything submitted before it complete and visible): the step binds
  // what else it needs. Its first range begins the step (clears, layouts), its last ends it
  // (barriers to the next step, counters made readable).
  virtual void recordStep(const LightingPass& pass, uint32_t step, uint32_t first,
                          uint32_t count) = 0;
  // The layout the lighting leaves hdr and lightCount in (what record() returns).
  virtual VkImageLayout lightingLayout() const = 0;

  // An instance for the renderer's one split frame: the same pipelines, its own lists, counters
  // and set 2, so the whole frames rendered between the split frame's parts leave them as its
  // earlier parts wrote them. Null (the default): the technique keeps nothing between steps that
  // another frame would overwrite; the split frame uses this instance.
  virtual std::unique_ptr<LightingTechnique> splitInstance(const TechniqueSetup& setup) {
    (void)setup;
    return nullptr;
  }
  // Whether the lists the steps before and including `step` built are complete once it ran: a
  // split frame then reads the counters (made host-readable at that step's end when
  // LightingPass::split) and, when the lists overflowed and grow (growLists), records the lighting
  // again from its first step, before any pixel was shaded from them.
  virtual bool listsBuiltAfter(uint32_t step) const {
    (void)step;
    return false;
  }
  // How many of the `units` of `step` that steps() gave have work, once every step before it ran
  // (a split frame asks when the step begins a part; what the host reads was made readable by
  // an earlier step with LightingPass::split): the units from there on are not recorded.
  // Clustered's large lights' passes: as many as were queued. Default: all of them.
  virtual uint32_t unitsWithWork(uint32_t step, uint32_t units) const {
    (void)step;
    return units;
  }
  // What each unit of `step` costs relative to the others, once every step before it ran (a
  // split frame asks when the step begins a part; what the host reads was made readable by an
  // earlier step with LightingPass::split). Empty (the default): its units cost about the same.
  // A split frame sizes its ranges by them: a tile of sky and a tile of long light lists differ
  // a thousandfold.
  virtual std::vector<float> unitWeights(uint32_t step, VkExtent2D extent) const {
    (void)step;
    (void)extent;
    return {};
  }

  // The host-readable buffer its shaders count into (a CullingStats), or null. The renderer
  // copies it into the frame slot's own buffer at the end of each frame (record() leaves it
  // ready for a transfer read after the compute stage), so frames in flight keep their counters.
  virtual const gpu::Buffer* counters() const { return nullptr; }

  // After the frame's GPU work finished: the culling counters (`counters`: the frame's copy of
  // counters(), sizeof(CullingStats) bytes; null when counters() is), list memory and capacity.
  virtual void report(CullingReport& report, const void* counters) const {
    (void)report;
    (void)counters;
  }

  // After a frame whose report says lights were dropped: makes the lists larger if memory allows,
  // and returns true when the frame should be rendered again with them.
  virtual bool growLists(const CullingReport& report) {
    (void)report;
    return false;
  }
  // Rendering again after growLists() failed for memory: back to the previous size, and never
  // try the failed one again.
  virtual void growthFailed() {}
  // For tests: see Renderer::limitListMemory.
  virtual void limitListMemory(uint64_t bytes, uint64_t startBytes) {
    (void)bytes;
    (void)startBytes;
  }

  // GPU memory the technique holds.
  virtual uint64_t gpuMemoryBytes() const { return 0; }
};

// The pipelines a technique created, destroyed together with it.
class PipelineList {
 public:
  explicit PipelineList(VkDevice device) : device_(device) {}
  ~PipelineList() {
    for (VkPipeline p : pipelines_) vkDestroyPipeline(device_, p, nullptr);
  }
  PipelineList(const PipelineList&) = delete;
  PipelineList& operator=(const PipelineList&) = delete;

  VkPipeline add(VkPipeline pipeline) {
    pipelines_.push_back(pipeline);
    return pipeline;
  }

 private:
  VkDevice device_;
  std::vector<VkPipeline> pipelines_;
};

}  // namespace myriad::render
