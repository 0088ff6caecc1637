// Distance fog (settings "fog"; shaders/fog.comp): on the lit picture, before the final pass
// tonemaps it, each surface keeps exp(-density * distance) of its radiance and takes the rest
// from the fog's colour. The fog is a full-screen pass rather than a term in every lighting
// technique's shader so that the techniques, the blend pass and the emissive surfaces are all
// fogged once, alike, and a frame without fog pays nothing.
#include "embedded_shaders.h"
#include "render/frame_pass.h"

namespace myriad::render::frame_passes {

const FramePass& fog() {
  static const FramePass pass{
      "fog", FramePassPlace::Hdr, 0,
      // The G-buffer's depth is read through its sampled binding, as every pass after the
      // G-buffer may without declaring it.
      {{FrameImage::Hdr, ImageAccess::StorageReadWrite}},
      spirv::fog_comp, MYRIAD_PIXEL_GROUP,
      // The pictures of the lighting only (the data views show no hdr), with some fog.
      [](const FrameSettings& s, const SceneBuffers&) {
        return s.fog.density > 0.0f &&
               (s.target == Target::Final || s.target == Target::LightVolumes);
      }};
  return pass;
}

}  // namespace myriad::render::frame_passes
