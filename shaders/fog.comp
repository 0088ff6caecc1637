#version 450
#extension GL_GOOGLE_include_directive : require
// Distance fog (render/frame_passes/fog.cpp): hdr = mix(fog colour, hdr, exp(-density * d)) at
// each pixel with a surface, d its distance in metres from the camera (position from depth, as the
// lighting finds it); pixels with no surface keep the background they show.
#include "shared_types.h"

layout(std140, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_DEPTH) uniform sampler2D gbufferDepth;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr;

#include "cluster_grid.glsl"  // worldFromDepth

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

void main() {
  const ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, ivec2(frame.viewport.xy)))) return;
  const float depth = texelFetch(gbufferDepth, p, 0).r;
  if (depth >= 1.0) return;  // no surface: the background or the environment, left as it is
  const float metres = length(worldFromDepth(p, depth) - frame.cameraPosition.xyz);
  const float kept = exp(-frame.fog.w * metres);
  const vec4 c = imageLoad(hdr, p);
  imageStore(hdr, p, vec4(mix(frame.fog.rgb, c.rgb, kept), c.a));
}
