#version 450
#extension GL_GOOGLE_include_directive : require
// Anti-aliasing of `final` (settings.antialias = "fxaa"), after tonemapping: a luminance-edge
// filter in the manner of Lottes' FXAA (NVIDIA 2009), written for this project. The final pass
// left the sRGB-encoded colour and its luma in the LDR target, and
//  1. measured the luma range of each pixel and its four neighbours (antialias.glsl): below the
//     contrast threshold it wrote the pixel to the output unchanged (most of the picture), above
//     it listed the pixel. Here one thread per listed pixel (an indirect dispatch)
//  2. decides whether the edge through it runs along x or along y (second differences
//     of the 3x3 luma), and on which side of the pixel it lies (the steeper neighbour);
//  3. walks along the edge, half a pixel towards that side, with bilinear luma reads, in both
//     directions until the luma leaves the edge's mean (the ends of the stair step);
//  4. blends towards the side by how far the pixel is from the nearer end (a step becomes a ramp
//     along the edge), or by how much it stands out from its 3x3 mean (sub-pixel features),
//     whichever is more, with one bilinear read.
// Why a post-process and not MSAA or supersampling: it costs one pass of a few reads per pixel
// whatever the scene, needs no multisampled G-buffer (the lighting techniques read one sample
// per pixel), and runs the same on lavapipe and GPUs. What it cannot do: recover detail smaller
// than a pixel (thin wires stay broken), and it softens sharp texture edges a little.
#include "frame.glsl"
#include "antialias.glsl"

layout(local_size_x = MYRIAD_EDGES_PER_GROUP) in;

// RGBA8: rgb the tonemapped, sRGB-encoded colour, a its luma; sampled with a linear filter and
// clamp-to-edge (bilinear reads between pixels), fetched exactly with texelFetch.
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_LDR) uniform sampler2D ldrColor;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba8) uniform writeonly image2D outputImage;

// How strongly an isolated sub-pixel feature is blended with its neighbourhood (0 off, 1 full).
const float kSubpixelBlend = 0.75;
// The walk along an edge: pixels advanced per step; 12 steps reach 24 pixels each way, enough for
// the shallowest stair steps at the angles that alias most.
const int kSearchSteps = 12;
const float kSearchStride[kSearchSteps] =
    float[](1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 6.5);

ivec2 gLast;  // the last pixel of the image

float lumaAt(ivec2 p) {
  return texelFetch(ldrColor, clamp(p, ivec2(0), gLast), 0).a;
}

float lumaBetween(vec2 uv) {
  return textureLod(ldrColor, uv, 0.0).a;
}

void main() {
  if (gl_GlobalInvocationID.x >= edges.count.x) return;
  ivec2 pixel = unpackEdgePixel(edgePixels[gl_GlobalInvocationID.x]);
  gLast = ivec2(frame.viewport.xy) - 1;
  vec4 centre = texelFetch(ldrColor, pixel, 0);
  float m = centre.a;
  float up = lumaAt(pixel + ivec2(0, -1));
  float down = lumaAt(pixel + ivec2(0, 1));
  float left = lumaAt(pixel + ivec2(-1, 0));
  float right = lumaAt(pixel + ivec2(1, 0));
  float lowest = min(m, min(min(up, down), min(left, right)));
  float highest = max(m, max(max(up, down), max(left, right)));
  float range = highest - lowest;  // on an edge (the final pass listed the pixel): not 0
  float upLeft = lumaAt(pixel + ivec2(-1, -1));
  float upRight = lumaAt(pixel + ivec2(1, -1));
  float downLeft = lumaAt(pixel + ivec2(-1, 1));
  float downRight = lumaAt(pixel + ivec2(1, 1));

  // Sub-pixel: how far the centre stands out from the weighted mean of its 3x3 neighbourhood,
  // relative to the range, shaped so that only clear outliers blend much.
  float mean = (2.0 * (up + down + left + right) + upLeft + upRight + downLeft + downRight) / 12.0;
  float outlier = clamp(abs(mean - m) / range, 0.0, 1.0);
  outlier = outlier * outlier * (3.0 - 2.0 * outlier);
  float subpixelOffset = outlier * outlier * kSubpixelBlend;

  // Orientation: luma changing across rows (second difference in y, weighted to the centre
  // column) means an edge running along x.
  float changeAcrossRows = abs(upLeft - 2.0 * left + downLeft) + 2.0 * abs(up - 2.0 * m + down) +
                           abs(upRight - 2.0 * right + downRight);
  float changeAcrossColumns = abs(upLeft - 2.0 * up + upRight) + 2.0 * abs(left - 2.0 * m + right) +
                              abs(downLeft - 2.0 * down + downRight);
  bool alongX = changeAcrossRows >= changeAcrossColumns;

  // The side of the pixel the edge lies on: towards the neighbour with the larger luma change.
  vec2 texel = frame.viewport.zw;
  float before = alongX ? up : left;  // the neighbour at -1 across the edge
  float after = alongX ? down : right;
  float changeBefore = abs(before - m);
  float changeAfter = abs(after - m);
  bool towardsBefore = changeBefore >= changeAfter;
  float across = (alongX ? texel.y : texel.x) * (towardsBefore ? -1.0 : 1.0);
  float edgeLuma = 0.5 * (m + (towardsBefore ? before : after));
  // The walk stops where the luma between the two rows (columns) leaves the edge's mean by a
  // quarter of the step across it.
  float stopDelta = 0.25 * max(changeBefore, changeAfter);

  vec2 uvCentre = (vec2(pixel) + 0.5) * texel;
  vec2 uvEdge = uvCentre + (alongX ? vec2(0.0, 0.5 * across) : vec2(0.5 * across, 0.0));
  vec2 along = alongX ? vec2(texel.x, 0.0) : vec2(0.0, texel.y);
  vec2 uvNeg = uvEdge - along * kSearchStride[0];
  vec2 uvPos = uvEdge + along * kSearchStride[0];
  float deltaNeg = lumaBetween(uvNeg) - edgeLuma;
  float deltaPos = lumaBetween(uvPos) - edgeLuma;
  bool endNeg = abs(deltaNeg) >= stopDelta;
  bool endPos = abs(deltaPos) >= stopDelta;
  for (int i = 1; i < kSearchSteps && !(endNeg && endPos); ++i) {
    if (!endNeg) {
      uvNeg -= along * kSearchStride[i];
      deltaNeg = lumaBetween(uvNeg) - edgeLuma;
      endNeg = abs(deltaNeg) >= stopDelta;
    }
    if (!endPos) {
      uvPos += along * kSearchStride[i];
      deltaPos = lumaBetween(uvPos) - edgeLuma;
      endPos = abs(deltaPos) >= stopDelta;
    }
  }

  // Distances (in pixels) from the centre to both ends; the nearer end decides.
  float distNeg = alongX ? (uvCentre.x - uvNeg.x) / texel.x : (uvCentre.y - uvNeg.y) / texel.y;
  float distPos = alongX ? (uvPos.x - uvCentre.x) / texel.x : (uvPos.y - uvCentre.y) / texel.y;
  bool negNearer = distNeg < distPos;
  float nearest = min(distNeg, distPos);
  float edgeLength = distNeg + distPos;
  // Blend only on the side of the step where the centre's luma is on the other side of the edge
  // mean from the end's: that is where the staircase's corner needs filling.
  bool centreBelowEdge = m < edgeLuma;
  bool endBelowEdge = (negNearer ? deltaNeg : deltaPos) < 0.0;
  float edgeOffset = centreBelowEdge != endBelowEdge ? 0.5 - nearest / edgeLength : 0.0;

  float offset = max(edgeOffset, subpixelOffset);
  vec2 uvBlend = uvCentre + (alongX ? vec2(0.0, offset * across) : vec2(offset * across, 0.0));
  imageStore(outputImage, pixel, vec4(textureLod(ldrColor, uvBlend, 0.0).rgb, 1.0));
}
