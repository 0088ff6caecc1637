// A lighting technique: how one frame's local lights get into the HDR and light-count targets.
// Each technique is one file in this directory holding its pipelines, its buffers, its commands
// and its culling report; the frame function (renderer.cpp) calls it through this interface and
// knows none of them by name. registry.cpp lists them.
#pragma once

#include <cstdint>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "render/frame.h"
#include "render/frame_targets.h"
#include "render/gpu_types.h"
#include "render/passes.h"
#include "render/scene_buffers.h"
#include "shared_types.h"

namespace myriad::render {

// What a technique is built from: the device, and the frame's shared pipeline layout (sets 0-2;
// set 2, light culling, is the technique's to fill: see compute_lighting.h).
struct TechniqueSetup {
  gpu::Context& context;
  const Pipelines& pipelines;
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
  // gets its barrier here.
  virtual VkImageLayout record(const LightingPass& pass) = 0;

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

  // Lighting that is a sum over independently drawn lights may be recorded in ranges of lights,
  // each range in its own submission (Renderer::SplitFrame). recordBeforeLights records what
  // record() does before the first light (every pixel of hdr and lightCount written);
  // recordLightRange adds lights [first, first + count). Both leave hdr and lightCount in the
  // layout record() returns, which recordBeforeLights returns.
  virtual bool splitsByLights() const { return false; }
  virtual VkImageLayout recordBeforeLights(const LightingPass& pass) { return record(pass); }
  virtual void recordLightRange(const LightingPass& pass, uint32_t first, uint32_t count) {
    (void)pass;
    (void)first;
    (void)count;
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
