#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 5: each pixel shades sun + ambient + the lights in its cluster's list.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) return;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  Surface s;
  vec3 color = backgroundRadiance(pixel);
  uint reached = 0u;
  if (loadSurfaceWithDepth(pixel, depth, s)) {
    color = sunAndAmbient(s);
    uvec2 range = clusterRanges[clusterOfPixel(pixel, depth)];
    for (uint i = 0u; i < range.y; ++i) {
      uint index = clusterLights[range.x + i];
      if (lightReaches(s, index)) {
        color += shadeLight(s, index);
        ++reached;
      }
    }
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
