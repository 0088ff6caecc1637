#version 450
#extension GL_GOOGLE_include_directive : require
// The 8-bit final picture as JPEG's YCbCr 4:2:0 planes (JFIF: BT.601 at full range), for JPEG
// frames and streams (render::FrameSettings::yuv420): the host then reads back 1.5 bytes a pixel
// instead of 4 and libturbojpeg encodes from the planes without converting colours itself.
// Layout (render::yuv420Layout): Y rows of yStride = width rounded up to 8 bytes, height rounded
// up to 2 rows; then Cb, then Cr, each yStride / 2 bytes by rows / 2. Pixels past the picture
// repeat its last column and row, as libjpeg pads. A thread covers 8 x 2 pixels: four bytes of
// each of two Y rows twice, and four Cb and four Cr samples (each the mean of 2 x 2 pixels,
// converted once).
#include "shared_types.h"

layout(std140, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba8) uniform readonly image2D outputImage;
layout(std430, set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_YUV_PLANES) writeonly buffer PlanesBlock {
  uint planes[];
};

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

uint toByte(float v) {
  return uint(clamp(round(v), 0.0, 255.0));
}

void main() {
  const ivec2 size = ivec2(frame.viewport.xy);
  const uint yStride = (uint(size.x) + 7u) & ~7u;
  const uint rows = (uint(size.y) + 1u) & ~1u;
  const uvec2 block = gl_GlobalInvocationID.xy;
  if (block.x * 8u >= yStride || block.y * 2u >= rows) return;
  const ivec2 last = size - 1;
  uint y[4] = uint[](0u, 0u, 0u, 0u);  // row 0: words 0-1, row 1: words 2-3
  uint cb = 0u;
  uint cr = 0u;
  for (uint i = 0u; i < 4u; ++i) {
    vec3 sum = vec3(0.0);
    for (uint dy = 0u; dy < 2u; ++dy) {
      for (uint dx = 0u; dx < 2u; ++dx) {
        const uint column = i * 2u + dx;  // 0..7 within the block
        const ivec2 p = min(ivec2(block.x * 8u + column, block.y * 2u + dy), last);
        const vec3 rgb = imageLoad(outputImage, p).rgb * 255.0;
        sum += rgb;
        y[dy * 2u + column / 4u] |= toByte(dot(rgb, vec3(0.299, 0.587, 0.114))) << (8u * (column % 4u));
      }
    }
    const vec3 mean = sum * 0.25;
    cb |= toByte(dot(mean, vec3(-0.168736, -0.331264, 0.5)) + 128.0) << (8u * i);
    cr |= toByte(dot(mean, vec3(0.5, -0.418688, -0.081312)) + 128.0) << (8u * i);
  }
  const uint row0 = (block.y * 2u * yStride + block.x * 8u) / 4u;
  const uint row1 = row0 + yStride / 4u;
  planes[row0] = y[0];
  planes[row0 + 1u] = y[1];
  planes[row1] = y[2];
  planes[row1 + 1u] = y[3];
  const uint chromaStride = yStride / 2u;
  const uint cbAt = (yStride * rows + block.y * chromaStride + block.x * 4u) / 4u;
  planes[cbAt] = cb;
  planes[cbAt + chromaStride * rows / 8u] = cr;  // the Cr plane: chromaStride * rows / 2 bytes on
}
