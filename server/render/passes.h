// The frame's passes. Each pass is a function that records its commands and names, in its
// signature and its barriers, what it reads and what it writes. frame_recording.cpp and
// after_lighting.cpp call them in order; passes.cpp holds the raster ones and the markers,
// output_passes.cpp the final pass and what follows it, frame_pipelines.cpp their pipelines.
#pragma once

#include <array>

#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "render/frame.h"
#include "render/frame_pass.h"
#include "render/frame_targets.h"
#include "render/scene_buffers.h"

namespace myriad::render {

// The frame's pipeline layout (set 0 = scene, set 1 = targets, set 2 = light culling, set 3 = a
// material's textures) and the
// pipelines of the passes every technique shares. Each lighting technique makes its own
// pipelines with this layout (render/techniques/).
struct Pipelines {
  explicit Pipelines(gpu::Context& context);
  ~Pipelines();
  Pipelines(const Pipelines&) = delete;
  Pipelines& operator=(const Pipelines&) = delete;

  VkDevice device;
  VkDescriptorSetLayout sceneSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout targetSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout cullingSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout materialSetLayout = VK_NULL_HANDLE;  // set 3: one material's textures
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline gbuffer = VK_NULL_HANDLE;           // opaque materials
  VkPipeline gbufferAlphaTest = VK_NULL_HANDLE;  // alphaMode MASK: may discard
  VkPipeline gbufferUntextured = VK_NULL_HANDLE;  // opaque materials without any texture
  // The label pass (recordLabelPass): gbuffer.vert + labels.frag, depth EQUAL, read-only depth.
  VkPipeline labels = VK_NULL_HANDLE;
  // Alpha-blended surfaces (recordBlendPass): every light tested, or the clustered lists.
  VkPipeline forward = VK_NULL_HANDLE;
  VkPipeline forwardClustered = VK_NULL_HANDLE;
  VkPipeline shadow = VK_NULL_HANDLE;  // depth only, from a light (render/shadows.h)
  VkPipeline lightVolumeOverlay = VK_NULL_HANDLE;
  // Compute (render/compute_passes.h).
  VkPipeline animateLights = VK_NULL_HANDLE;
  VkPipeline markerSplat = VK_NULL_HANDLE;  // markers: one thread per light
  // The output, one thread per pixel: final (markers resolved, tonemapped), the data and debug
  // views, each for the 8-bit and the raw (float) output; then anti-aliasing of final.
  VkPipeline final = VK_NULL_HANDLE;
  uint32_t finalGroup = MYRIAD_PIXEL_GROUP;  // its local size (MYRIAD_FINAL_CPU_GROUP on CPU devices)
  // The 8-bit final pipeline for a frame with or without anti-aliasing and markers: `final` on
  // GPUs (it tests the frame's uniforms); on CPU devices final_cpu.comp specialised to exactly
  // those parts (MYRIAD_SPEC_FINAL_PARTS), made on first use (`final` is the one with both).
  VkPipeline finalFor(bool antialias, bool markers) const;
  VkPipeline finalRaw = VK_NULL_HANDLE;
  VkPipeline views = VK_NULL_HANDLE;
  VkPipeline viewsRaw = VK_NULL_HANDLE;
  // The views pipeline of `target`, 8-bit or raw: `views` / `viewsRaw`, or for the `shadow` view
  // the same shaders specialised to it alone (MYRIAD_SPEC_SHADOW_VIEW), made on first use.
  VkPipeline viewsFor(Target target, bool raw) const;
  VkPipeline antialias = VK_NULL_HANDLE;
  // CPU devices: anti-aliasing's edge test as a pass of its own (antialias_edges.comp), which
  // their final pass leaves out; null on GPUs (their final pass tests the edges).
  VkPipeline antialiasEdges = VK_NULL_HANDLE;
  VkPipeline yuv420 = VK_NULL_HANDLE;  // final as YCbCr 4:2:0 planes

 private:
  bool cpuFinal_ = false;
  mutable std::array<VkPipeline, 4> finalParts_{};  // CPU devices: by MYRIAD_FINAL_* bits
  mutable std::array<VkPipeline, 2> shadowViews_{};  // the `shadow` view's: 8-bit, raw
};

// 1. Writes depth, normal, base colour, material, and uv and emissive where `written`
// (MYRIAD_GBUFFER_* bits) says; leaves them readable by later passes. Each mesh drawn in the
// version `detail` chooses (the full one unless the frame allows coarser: MeshDetail).
void recordGBufferPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                       const SceneBuffers& scene, uint32_t written, const MeshDetail& detail = {});
// 2-3. The lighting technique's passes (render/techniques/technique.h).
// 3b. Alpha-blended (glTF BLEND) draws, sorted back to front by the view depth of each draw's
//    centre, depth-tested against the G-buffer depth without writing it, lit like opaque pixels
//    (sun, ambient or environment, emission, local lights) and blended `over` into HDR. Lights come
//    from the clustered lists when `clusterLists` (the technique bound them as set 2 at the
//    graphics bind point), else every light is tested. `hdrLayout`: where lighting left HDR
//    (GENERAL after compute, COLOR_ATTACHMENT after volumes); returns HDR's layout after it (COLOR_ATTACHMENT, or `hdrLayout` when nothing is blended).
// The label pass, right after the raster G-buffer pass (depth read-only): every opaque and
// alpha-tested draw again with labels.frag, depth EQUAL, the same versions of the meshes
// (`detail`), into t.labels (ensureLabels), cleared to 0; left ready for recordLabelReadback.
void recordLabelPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                     const SceneBuffers& scene, const MeshDetail& detail);
// Copies t.labels into `readback` (16 bytes a pixel, as raw output).
void recordLabelReadback(VkCommandBuffer cmd, const FrameTargets& t, const gpu::Buffer& readback);

VkImageLayout recordBlendPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                              const SceneBuffers& scene, const glm::mat4& view,
                              VkImageLayout hdrLayout, bool clusterLists);
// Whether the scene has alpha-blended draws (the clustered technique then marks their clusters).
bool hasBlendDraws(const SceneBuffers& scene);
// 4. Reads depth (test only, kept from pass 1) and lights; splats light markers (compute, a few
//    pixels each) into the marker keys, which the final pass resolves (blends into the picture).
void recordMarkerPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                      const SceneBuffers& scene);
// 5. Compute, one thread per pixel. `final`/`light-volumes`: reads HDR and (with `markers`) the
//    marker keys, writes the tonemapped picture to the output, or when the frame is anti-aliased
//    (`antialias`, as FrameUniforms.post.x says) to the LDR target for pass 5b. Other views: reads the G-buffer or light counts, writes the output.
//    `hdr` and `lightCount` are their last uses (render/frame_pass.h): the lighting's, the blend
//    pass's or a registered pass's. Leaves hdr and lightCount sampled and the output in
//    GENERAL. `first` and `count` select workgroups of the pass (finalPassGroups, row by row) for
//    a split frame; the first range makes the layouts and empties the edge list.
void recordFinalPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t, Target target,
                     bool markers, bool antialias, const ImageState& hdr,
                     const ImageState& lightCount, uint32_t first = 0,
                     uint32_t count = UINT32_MAX);
// The final pass's workgroups (across and down).
VkExtent2D finalPassGroups(const Pipelines& p, const FrameTargets& t, Target target);
// 5b. (final, 8-bit, antialias on) Reads the LDR target; writes the anti-aliased output.
void recordAntialiasPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t);
// 5c. (light-volumes view) Reads depth and lights; adds each volume's coverage to the output.
//     Leaves the output as a colour attachment.
void recordLightVolumeOverlayPass(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                                  const SceneBuffers& scene);
// 6. Reads the output image (`output`: its last use, GENERAL from compute, or COLOR_ATTACHMENT
//    after the overlay); writes it to the host-visible readback buffer.
// 5d. (FrameSettings::yuv420) Reads the 8-bit output (after `output`, its last use); writes its
//     YCbCr 4:2:0 planes (t.planes) and copies them into `readback` for the host.
void recordYuv420Readback(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                          const ImageState& output, const gpu::Buffer& readback);
// Copies the output into `readback` (t.readback, or a buffer of the renderer's readback pool).
void recordReadback(VkCommandBuffer cmd, const FrameTargets& t, const ImageState& output,
                    const gpu::Buffer& readback);

}  // namespace myriad::render
