// What the final pass (final_pass.glsl) and the anti-aliasing pass (antialias.comp) share: the
// luma they compare, the test that puts a pixel on an edge, and the list of edge pixels the first
// writes and the second filters. Splitting the work this way lets the final pass write every pixel
// off an edge (most of the picture) straight to the output, and the anti-aliasing pass run one
// thread per edge pixel (an indirect dispatch) instead of one per pixel.
#ifndef MYRIAD_ANTIALIAS_GLSL
#define MYRIAD_ANTIALIAS_GLSL

layout(std430, set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_EDGE_PIXELS) buffer EdgeBlock {
  AntialiasEdges edges;
  uint edgePixels[];  // x | y << 16
};

// A pixel is on an edge when the luma range of its cross exceeds both of these: an absolute
// floor (noise in dark regions is no edge; 8/255) and a share of the brightest luma there (a
// step of 1/8 of the local brightness is visible, a smaller one is texture).
const float kMinContrast = 0.0312;
const float kRelativeContrast = 0.125;

// Luma of an sRGB-encoded colour (Rec. 601 weights), rounded to the 8 bits the LDR target keeps
// in alpha: what the edge test and the edge walk compare. Gamma space on purpose: a step is
// judged by how it looks, not by its linear energy.
float perceivedLuma(vec3 encoded) {
  return floor(clamp(dot(encoded, vec3(0.299, 0.587, 0.114)), 0.0, 1.0) * 255.0 + 0.5) / 255.0;
}

bool onEdge(float lowest, float highest) {
  return highest - lowest >= max(kMinContrast, highest * kRelativeContrast);
}

uint packEdgePixel(ivec2 pixel) {
  return uint(pixel.x) | (uint(pixel.y) << 16);
}

ivec2 unpackEdgePixel(uint packed) {
  return ivec2(int(packed & 0xffffu), int(packed >> 16));
}

#endif
