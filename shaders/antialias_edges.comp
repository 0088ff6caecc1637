#version 450
#extension GL_GOOGLE_include_directive : require
// Anti-aliasing's first step on CPU devices (final_pass.glsl's CPU main says why it is a pass of
// its own there): the edge test of each pixel's cross, read from the LDR target the final pass
// wrote. A pixel off an edge goes to the output as it is; an edge pixel is listed for
// antialias.comp (one global atomic each: a few percent of the pixels). The same test on the same
// 8-bit values as the GPUs' final pass, so the same pixels are listed and the image is the same
// (the list's order differs; each entry is filtered alone).
#include "frame.glsl"
#include "antialias.glsl"

layout(local_size_x = MYRIAD_FINAL_CPU_GROUP, local_size_y = MYRIAD_FINAL_CPU_GROUP) in;

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_LDR) uniform sampler2D ldrColor;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba8) uniform writeonly image2D outputImage;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 last = ivec2(frame.viewport.xy) - 1;
  if (any(greaterThan(pixel, last))) return;
  vec4 centre = texelFetch(ldrColor, pixel, 0);
  float up = texelFetch(ldrColor, ivec2(pixel.x, max(pixel.y - 1, 0)), 0).a;
  float down = texelFetch(ldrColor, ivec2(pixel.x, min(pixel.y + 1, last.y)), 0).a;
  float left = texelFetch(ldrColor, ivec2(max(pixel.x - 1, 0), pixel.y), 0).a;
  float right = texelFetch(ldrColor, ivec2(min(pixel.x + 1, last.x), pixel.y), 0).a;
  float lowest = min(centre.a, min(min(up, down), min(left, right)));
  float highest = max(centre.a, max(max(up, down), max(left, right)));
  if (onEdge(lowest, highest)) {
    uint slot = atomicAdd(edges.count.x, 1u);
    atomicMax(edges.groups.x, (slot + MYRIAD_EDGES_PER_GROUP) / MYRIAD_EDGES_PER_GROUP);
    edgePixels[slot] = packEdgePixel(pixel);
  } else {
    imageStore(outputImage, pixel, vec4(centre.rgb, 1.0));
  }
}
