// The frame's commands: its start (sets bound, the timer reset), the passes before the lighting
// (environment, skinning, BVH, animation, shadows, G-buffer), and the whole frame in order.
#include <optional>

#include "gpu/commands.h"
#include "render/compute_passes.h"
#include "render/renderer_state.h"
#include "scene/camera.h"

namespace myriad::render {

void waitForEarlier(VkCommandBuffer cmd) {
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

// Begins the slot's command buffer with its sets 0 and 1 bound for graphics and compute and its
// timer reset. The first command waits for everything submitted before (frames in flight share
// the scenes' lights, the techniques' lists and counters, and write them without other
// barriers); the frames' host work overlaps, their GPU work runs in order.
VkCommandBuffer Renderer::State::beginFrameCommands(FrameSlot& slot, bool waitAtStart) {
  VkCommandBuffer cmd = gpu::beginCommands(context, slot.recorder);
  if (waitAtStart) waitForEarlier(cmd);
  VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines.layout, 0, 2, sets, 0,
                          nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelines.layout, 0, 2, sets, 0,
                          nullptr);
  slot.timer->reset(cmd);
  return cmd;
}

// environment (when its inputs changed), animate (or restoring the origins), shadow, gbuffer.
void Renderer::State::recordBeforeLighting(VkCommandBuffer cmd, FrameSlot& slot,
                                           SceneBuffers& scene, SceneEnvironment* environment,
                                           const FrameSettings& settings) {
  State& s = *this;
  const Pipelines& p = s.pipelines;
  if (slot.targets->clusterMarksFresh) {
    // New targets: no cluster marked (later frames leave them so; FrameTargets).
    vkCmdFillBuffer(cmd, slot.targets->clusterMarks.buffer, 0, VK_WHOLE_SIZE, 0u);
    gpu::bufferBarrier(cmd, slot.targets->clusterMarks, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    slot.targets->clusterMarksFresh = false;
  }
  if (environment) {
    const SceneEnvironment::Inputs inputs = EnvironmentPasses::inputsFor(settings, *environment);
    if (environment->built != inputs) {
      slot.timer->beginPass(cmd, "environment");
      environmentPasses->record(cmd, *environment, inputs);
      // The environment passes bound their own layout's set 0; the frame's sets go back.
      VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
    }
  }

  // Skinned and morphed instances posed (when the pose changed), before anything draws them.
  if (const bool previous = settings.target == Target::Motion && settings.previousPose != nullptr;
      SkinningPass::needed(scene, previous)) {
    skinning.record(cmd, scene, previous, *slot.timer);
    // It bound its own layout's set; the frame's go back.
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  }
  if (StochasticShadows::wanted(settings)) {
    // The BVH of the posed triangles, for the shadow rays of the lighting.
    stochastic.recordBvh(cmd, scene, *slot.timer);
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  }
  if (settings.animate) {
    // Or the lighting technique moves them, while it walks them (LightingPass::animateLights).
    if (!s.technique(settings.technique).animatesLights()) {
      slot.timer->beginPass(cmd, "animate");
      recordAnimateLights(cmd, p, scene);
    }
    scene.lightsMoved = true;
  } else if (scene.lightsMoved) {
    recordRestoreLights(cmd, scene);
    scene.lightsMoved = false;
  }
  if (const std::optional<SunShadowFit> sunShadow = sunShadowFor(scene, settings)) {
    // Drawn again only when the scene or the fit changed (ShadowMaps::sunHolds): not for a light,
    // material or slider change, animated lights, or (one cascade) a camera move; cascades
    // follow the camera, so a camera that stays keeps them.
    // After a few objects moved, only the texels under their old and new places (repairSun).
    slot.sunMap = Frame::SunMap::kept;
    if (!slot.shadows->sunHolds(scene, *sunShadow)) {
      slot.timer->beginPass(cmd, "shadow");  // names-once: the pass, not the target
      slot.sunMap = Frame::SunMap::repaired;
      if (!slot.shadows->repairSun(cmd, p, scene, *sunShadow)) {
        // After a camera move, cascades keep what they still cover (scrollSun).
        slot.sunMap = Frame::SunMap::scrolled;
        if (!s.tuning.sunScroll.value_or(false) ||
            !slot.shadows->scrollSun(cmd, p, scene, *sunShadow)) {
          slot.shadows->recordSun(cmd, p, scene, *sunShadow);
          slot.sunMap = Frame::SunMap::drawn;
        }
      }
    }
  } else {
    slot.sunMap = Frame::SunMap::none;
    slot.shadows->recordSunUnused(cmd);
  }
  if (!slot.lightShadows.empty()) {
    slot.timer->beginPass(cmd, "light-shadows");
    slot.shadows->recordLights(cmd, p, scene, slot.lightShadows);
  } else {
    slot.shadows->recordAtlasUnused(cmd);
  }
  if (computeGBufferFor(scene, settings)) {
    computeGBuffer.record(cmd, slot.visibility, *slot.targets, scene, slot.sceneSet, *slot.timer);
    // Its passes bound their own layout's sets; the frame's go back.
    VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 2, sets, 0, nullptr);
  } else {
    slot.timer->beginPass(cmd, "gbuffer");
    recordGBufferPass(cmd, p, *slot.targets, scene, gbufferWrites(settings, scene),
                      MeshDetail::of(settings));
    if (settings.drawsLabels()) {
      slot.timer->beginPass(cmd, "labels");
      recordLabelPass(cmd, p, *slot.targets, scene, MeshDetail::of(settings));
    }
    if (settings.target == Target::Motion) {
      slot.timer->beginPass(cmd, "motion");  // names-once: the pass, not the target
      const scene::Camera& previous = settings.previousCamera.value_or(settings.camera);
      const float aspect = float(settings.width) / float(settings.height);
      motion.record(cmd, *slot.targets, scene, slot.sceneSet,
                    scene::projectionMatrix(previous, aspect) * scene::viewMatrix(previous),
                    settings.previousPose != nullptr, MeshDetail::of(settings));
      // Its layout is not the frame's: the frame's sets go back.
      VkDescriptorSet sets[] = {slot.sceneSet, slot.targetSet};
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 2, sets, 0, nullptr);
    }
  }
}

// The frame, top to bottom, in one submission. Every request (any view, any size, any technique)
// takes this path, or the same steps split (beginSplit).
void Renderer::State::recordFrame(FrameSlot& slot, SceneBuffers& scene,
                                  SceneEnvironment* environment, const FrameSettings& settings,
                                  bool waitAtStart) {
  LightingTechnique& technique = this->technique(settings.technique);
  const bool madeTargets = prepareFrame(slot, scene, environment, settings, technique);
  VkCommandBuffer cmd = beginFrameCommands(slot, waitAtStart);
  recordBeforeLighting(cmd, slot, scene, environment, settings);
  // The technique's lists and counters are shared by frames in flight: the earlier frames are
  // done with them (their lighting, blend pass and counter copy) before this one resets them.
  if (!waitAtStart) waitForEarlier(cmd);
  // Lighting leaves HDR and light counts as attachments (raster) or storage images (compute).
  LightingPass lighting{cmd, *slot.timer, *slot.targets, scene, slot.shadingFeatures,
                       settings.animate && technique.animatesLights(),
                       computeGBufferFor(scene, settings)};
  if (StochasticShadows::wanted(settings)) lighting.stochastic = &stochastic;
  const VkImageLayout lightingLayout = technique.record(lighting);
  recordAfterLighting(cmd, slot, scene, settings, technique, lightingLayout);
  slot.meta = metaOf(scene, environment, settings);
  slot.meta.madeTargets = madeTargets;
}

Frame Renderer::State::renderOnce(FrameSlot& slot, SceneBuffers& scene,
                                  SceneEnvironment* environment, const FrameSettings& settings) {
  recordFrame(slot, scene, environment, settings);
  gpu::submitAndWait(context, slot.recorder);
  return readFrame(slot, slot.meta, settings, this->technique(settings.technique));
}

}  // namespace myriad::render
