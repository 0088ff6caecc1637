// Light volumes (the seed's technique): a full-screen sun pass writes sun + ambient (or the
// background) into every pixel, then one instanced draw of proxy spheres adds each light inside
// its sphere with additive blending (shaders/sun.frag, light_volume.vert/.frag). No culling and
// nothing on the GPU besides its two pipelines; cost grows with the pixels the spheres cover.
#include <array>
#include <memory>

#include "embedded_shaders.h"
#include "gpu/commands.h"
#include "gpu/pipelines.h"
#include "render/raster.h"
#include "render/techniques/technique.h"

namespace myriad::render {

namespace {

class Volumes final : public LightingTechnique {
 public:
  explicit Volumes(const TechniqueSetup& setup) : pipelines_(setup.context.device) {
    VkDevice device = setup.context.device;
    // Each pipeline twice: with the clear coat and sheen code compiled out (frames whose scene
    // has neither: llvmpipe would run it behind the uniform test too) and with every feature.
    const VkSpecializationMapEntry entry{MYRIAD_SPEC_SHADING_FEATURES, 0, sizeof(uint32_t)};
    const uint32_t withoutLayers = MYRIAD_FEATURES_ALL & ~MYRIAD_FEATURE_LAYERS;
    const VkSpecializationInfo plain{1, &entry, sizeof(uint32_t), &withoutLayers};
    for (const bool layered : {false, true}) {
      gpu::GraphicsPipelineDesc d;
      d.vertexShader = spirv::fullscreen_vert;
      d.fragmentShader = spirv::sun_frag;
      d.colorFormats = {kHdrFormat, kLightCountFormat};
      d.fragmentSpecialization = layered ? nullptr : &plain;
      const VkPipelineLayout layout = setup.pipelines.layout;
      sun_[layered] = pipelines_.add(gpu::createGraphicsPipeline(device, layout, d));

      d = lightVolumeDesc(setup.context);
      d.fragmentShader = spirv::light_volume_frag;
      d.colorFormats = {kHdrFormat, kLightCountFormat};
      d.fragmentSpecialization = layered ? nullptr : &plain;
      volumes_[layered] = pipelines_.add(gpu::createGraphicsPipeline(device, layout, d));
    }
  }

  // Two steps: the sun (every pixel), then the lights. Each light is one instance of the proxy,
  // added by blending: any range of them can be drawn in a submission of its own.
  std::vector<Step> steps(const LightingPass& pass) const override {
    return {{"sun", 1}, {"lights", pass.scene.lightCount}};
  }

  void recordStep(const LightingPass& pass, uint32_t step, uint32_t first,
                  uint32_t count) override {
    const bool layered = (pass.shadingFeatures & MYRIAD_FEATURE_LAYERS) != 0u;
    if (step == 0) {
      recordSun(pass.cmd, pass.targets, layered);
    } else {
      recordLights(pass.cmd, pass.targets, pass.scene, first, count, layered);
    }
  }

  VkImageLayout lightingLayout() const override { return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL; }

 private:
  // Reads the G-buffer; writes sun + ambient (or the background) into every HDR pixel and zero
  // light counts.
  void recordSun(VkCommandBuffer cmd, const FrameTargets& t, bool layered) const {
    const gpu::ImageTransition before[] = {
        // Last read by the previous frame's final or views pass (compute).
        discardForColorWrite(t.hdr, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT),
        discardForColorWrite(t.lightCount, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT)};
    gpu::barrier(cmd, before);
    // Every pixel is written (background included), so nothing is loaded or cleared.
    std::array<VkRenderingAttachmentInfo, 2> colors = {
        colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_DONT_CARE),
        colorAttachment(t.lightCount, VK_ATTACHMENT_LOAD_OP_DONT_CARE)};
    beginRendering(cmd, t.extent, colors, nullptr);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sun_[layered]);
    vkCmdDraw(cmd, 3, 1, 0, 0);
    vkCmdEndRendering(cmd);
  }

  // Reads the G-buffer and lights [first, first + count); adds each light's contribution to HDR
  // inside its sphere, and 1 to the light count there.
  void recordLights(VkCommandBuffer cmd, const FrameTargets& t, const SceneBuffers& scene,
                    uint32_t first, uint32_t count, bool layered) const {
    const gpu::ImageTransition before[] = {colorWriteToBlend(t.hdr), colorWriteToBlend(t.lightCount)};
    gpu::barrier(cmd, before);
    std::array<VkRenderingAttachmentInfo, 2> colors = {
        colorAttachment(t.hdr, VK_ATTACHMENT_LOAD_OP_LOAD),
        colorAttachment(t.lightCount, VK_ATTACHMENT_LOAD_OP_LOAD)};
    VkRenderingAttachmentInfo depth = readOnlyDepth(t.depth);
    beginRendering(cmd, t.extent, colors, &depth);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, volumes_[layered]);
    drawLightProxies(cmd, scene, first, count);
    vkCmdEndRendering(cmd);
  }

  PipelineList pipelines_;
  VkPipeline sun_[2] = {};      // [scene has layers]
  VkPipeline volumes_[2] = {};
};

}  // namespace

std::unique_ptr<LightingTechnique> createVolumes(const TechniqueSetup& setup) {
  return std::make_unique<Volumes>(setup);
}

}  // namespace myriad::render
