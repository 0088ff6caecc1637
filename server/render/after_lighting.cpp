// The passes after the lighting, as the list of steps State::afterSteps (built by the
// constructor): the forward passes (blend, markers), the registered passes on HDR, the final
// pass, anti-aliasing with the light-volumes overlay and the counters' copy, the registered
// passes on the output, the readback. A whole frame records them in order; a split frame records
// each as a step of its own, in ranges of its units. The images they hand on to each other (hdr,
// lightCount, the output) carry their last use in a FrameImageStates, from which each pass's
// first barrier is made.
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>

#include "gpu/commands.h"
#include "render/extra_targets.h"
#include "render/renderer_state.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

// A label frame: the label pass drew everything it shows; its image is the output. The motion
// pass, likewise, drew the output.
bool outputDrawnBeforeLighting(const FrameSettings& settings) {
  return isLabel(settings.target) || settings.target == Target::Motion;
}

}  // namespace

FrameImageStates Renderer::State::afterLightingStates(VkImageLayout lightingLayout,
                                                      const FrameSettings& settings) {
  FrameImageStates images;
  images[FrameImage::Hdr] = writtenIn(lightingLayout);
  images[FrameImage::LightCount] = writtenIn(lightingLayout);
  // The output: not written yet (the final pass discards it), or drawn by the motion pass.
  if (settings.target == Target::Motion) {
    images[FrameImage::Output] = writtenIn(VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  }
  return images;
}

uint32_t Renderer::State::afterUnits(const AfterStep& step, const FrameSlot& slot,
                                     const SceneBuffers& scene,
                                     const FrameSettings& settings) const {
  const bool drawn = outputDrawnBeforeLighting(settings);
  switch (step.kind) {
    case AfterStep::Forward:
      return !drawn && (hasBlendDraws(scene) || settings.markers) ? 1u : 0u;
    case AfterStep::Final: {
      if (drawn) return 0;
      const VkExtent2D groups = finalPassGroups(pipelines, *slot.targets, settings.target);
      return groups.width * groups.height;
    }
    case AfterStep::Antialias:
      return drawn ? 0u : 1u;
    case AfterStep::Registered: {
      if (drawn || (step.pass->wanted && !step.pass->wanted(settings, scene))) return 0;
      const VkExtent2D extent = slot.targets->extent;
      return gpu::groupCount(extent.width, step.pass->groupSize) *
             gpu::groupCount(extent.height, step.pass->groupSize);
    }
    default:
      return 1;
  }
}

void Renderer::State::recordAfterStep(VkCommandBuffer cmd, const FrameSlot& slot,
                                      SceneBuffers& scene, const FrameSettings& settings,
                                      LightingTechnique& technique, FrameImageStates& images,
                                      const AfterStep& step, uint32_t first, uint32_t count) {
  const Pipelines& p = pipelines;
  const FrameTargets& t = *slot.targets;
  const bool antialias = settings.antialiased();  // as FrameUniforms.post.x says
  ImageState& hdr = images[FrameImage::Hdr];
  ImageState& output = images[FrameImage::Output];
  switch (step.kind) {
    case AfterStep::Forward:
      if (hasBlendDraws(scene)) {
        slot.timer->beginPass(cmd, "blend");
        hdr = writtenIn(recordBlendPass(cmd, p, t, scene, scene::viewMatrix(settings.camera),
                                        hdr.layout, technique.bindForwardLights(cmd)));
      }
      if (settings.markers) {
        slot.timer->beginPass(cmd, "markers");
        recordMarkerPass(cmd, p, t, scene);
      }
      break;
    case AfterStep::Final: {
      slot.timer->beginPass(cmd, "final");  // names-once: the pass, not the target
      ImageState& lightCount = images[FrameImage::LightCount];
      recordFinalPass(cmd, p, t, settings.target, settings.markers, antialias, hdr, lightCount,
                      first, count);
      // It samples both in compute (every range after the first keeps them so) and stores the
      // output.
      hdr = lightCount = {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
      output = writtenIn(VK_IMAGE_LAYOUT_GENERAL);
      break;
    }
    case AfterStep::Antialias:
      if (antialias) {
        slot.timer->beginPass(cmd, "antialias");
        recordAntialiasPass(cmd, p, t);  // the output's pixels on edges: still GENERAL, stored
      }
      if (temporal->holds(slot.temporal, t.extent)) {
        // A stream's taa frame: resolved against its history (render/temporal.h).
        slot.timer->beginPass(cmd, "taa");
        temporal->record(cmd, t, slot.temporal, slot.sceneSet);
        // Its layout is not the frame's: the frame's sets go back.
        VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
        output = writtenIn(VK_IMAGE_LAYOUT_GENERAL);
      }
      if (settings.target == Target::LightVolumes && !settings.raw) {
        slot.timer->beginPass(cmd, "overlay");
        recordLightVolumeOverlayPass(cmd, p, t, scene);
        output = writtenIn(VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
      }
      if (const gpu::Buffer* counters = technique.counters()) {
        // The frame's own copy of the culling counters: the next frame in flight resets the
        // technique's (record() made them readable by a copy).
        const VkBufferCopy region{0, 0, sizeof(CullingStats)};
        vkCmdCopyBuffer(cmd, counters->buffer, slot.counters.buffer, 1, &region);
        gpu::bufferBarrier(cmd, slot.counters, VK_PIPELINE_STAGE_2_COPY_BIT,
                           VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                           VK_ACCESS_2_HOST_READ_BIT);
      }
      break;
    case AfterStep::Registered: {
      slot.timer->beginPass(cmd, step.pass->name);
      // A later range of a split frame's pass: the first range made the barriers.
      if (first == 0) recordUseBarriers(cmd, t, step.pass->uses, images);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, step.pipeline);
      gpu::dispatchGroupRange(cmd, gpu::groupCount(t.extent.width, step.pass->groupSize),
                              gpu::groupCount(t.extent.height, step.pass->groupSize), first,
                              count);
      break;
    }
    case AfterStep::Readback: {
      const gpu::Buffer& readback = slot.readback ? slot.readback->buffer : t.readback;
      if (isLabel(settings.target)) {
        slot.timer->beginPass(cmd, "readback");
        recordLabelReadback(cmd, t, readback);
      } else if (settings.yuv420Readback()) {
        slot.timer->beginPass(cmd, "yuv");
        recordYuv420Readback(cmd, pipelines, t, output, readback);
      } else {
        slot.timer->beginPass(cmd, "readback");
        recordReadback(cmd, t, output, readback);
      }
      if (!settings.alsoRead.empty()) {
        // A multi-target frame: its other targets from this same render.
        slot.timer->beginPass(cmd, "extra-targets");
        uint32_t hostFlags[4];
        std::memcpy(hostFlags,
                    static_cast<const uint8_t*>(slot.uniforms.mapped) + offsetof(FrameUniforms, flags),
                    sizeof hostFlags);
        recordExtraTargets(cmd, p, t, settings, slot.uniforms, offsetof(FrameUniforms, flags),
                           hostFlags, p.layout, slot.rawTargetSet,
                           slot.readback ? ExtraDestination{&readback, extrasOffset(settings)}
                                         : ExtraDestination{&t.extraReadback, 0});
      }
      break;
    }
    default:
      throw std::logic_error("no step " + std::to_string(step.kind) + " after the lighting");
  }
}

void Renderer::State::recordAfterLighting(VkCommandBuffer cmd, const FrameSlot& slot,
                                          SceneBuffers& scene, const FrameSettings& settings,
                                          LightingTechnique& technique,
                                          VkImageLayout lightingLayout) {
  FrameImageStates images = afterLightingStates(lightingLayout, settings);
  for (const AfterStep& step : afterSteps) {
    const uint32_t units = afterUnits(step, slot, scene, settings);
    if (units > 0) {
      recordAfterStep(cmd, slot, scene, settings, technique, images, step, 0, units);
    }
  }
  slot.timer->end(cmd);
}

}  // namespace myriad::render
