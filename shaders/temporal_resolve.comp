#version 450
#extension GL_GOOGLE_include_directive : require
// Temporal anti-aliasing of a stream's frames (antialias=taa with FrameSettings::historyKey;
// render/temporal.h): one jittered frame resolved against the stream's history, on the GPU.
//  1. this pixel's sub-pixel sample (the projection was jittered by push.jitter) and its 4
//     neighbours sharing an edge, in linear light (read through an sRGB view: the sampler
//     decodes, no pow) and taken to YCoCg: their box (min, max);
//  2. the history reprojected: the point the nearest depth of those 5 reconstructs (unjittered
//     NDC) taken to the previous frame's screen by push.reprojection (the camera's motion; the
//     stream's previous view-projection times this one's inverse), read there through a
//     Catmull-Rom filter (historyAt);
//  3. the history rejected where that lands off-screen or behind the previous camera, or where
//     every one of the previous frame's 2x2 view depths around it is nearer, by more than
//     push.limits.x, than the depth the point had then (a disocclusion: something covered it);
//  4. the history clamped to the box and blended: the current frame's weight is 1 / (samples
//     the history held + 1), at least push.params.w (0.1: an exponential average once long);
//  5. the result written to the output (sRGB) and, with its sample count and this frame's view
//     depth, to the next history.
// No branch depends on a push constant (docs/ARCHITECTURE.md section 6): whether there is a
// history at all (push.params.z) is a factor of the validity, computed per pixel.
#include "shared_types.h"

// Read with texelFetch through samplers (nearest): llvmpipe's vectorised texture path, cheaper
// than its storage-image loads.
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_CURRENT) uniform sampler2D current;  // sRGB: linear
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_DEPTH) uniform sampler2D depthImage;
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_HISTORY) uniform sampler2D history;
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_HISTORY_DEPTH) uniform sampler2D historyDepth;
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_NEXT, rgba16f) uniform writeonly image2D nextHistory;
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_NEXT_DEPTH, r32f) uniform writeonly image2D nextDepth;
layout(set = 0, binding = MYRIAD_TEMPORAL_BINDING_OUTPUT, rgba8) uniform writeonly image2D outputImage;

layout(push_constant) uniform PushBlock {
  TemporalPush push;
};

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

vec3 toSrgb(vec3 v) {
  v = clamp(v, vec3(0.0), vec3(1.0));
  return mix(v * 12.92, 1.055 * pow(v, vec3(1.0 / 2.4)) - 0.055, greaterThan(v, vec3(0.0031308)));
}

vec3 toYCoCg(vec3 c) {
  return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b,
              -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}

vec3 fromYCoCg(vec3 c) { return vec3(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z); }

// Depth (0 near, 1 far; perspectiveRH_ZO) -> view depth in metres.
float viewDepth(float z) {
  const float n = push.params.x, f = push.params.y;
  return n * f / max(f - z * (f - n), 1e-20);
}

// The history at `at` (pixels) through a Catmull-Rom filter, as 5 bilinear reads (Jimenez,
// "Filmic SMAA", 2016: the 4x4 footprint's corners left out, the weights renormalised): bilinear
// alone blurs a little more at every frame a moving camera resamples it. At a texel's centre
// (a still camera) it is that texel exactly. Its sample count (alpha): the middle read's.
vec4 historyAt(vec2 at, vec2 size) {
  const vec2 one = vec2(1.0) / size;
  const vec2 centre1 = floor(at - 0.5) + 0.5;
  const vec2 f = at - centre1;
  // Within a hundredth of a pixel of a texel's centre (a still camera): that texel, one read. A branch on the pixel's own motion, not on a uniform: on llvmpipe a group of
  // pixels all at rest skips the filter.
  if (all(lessThan(min(f, 1.0 - f), vec2(0.01)))) {
    return texelFetch(history, clamp(ivec2(round(at - 0.5)), ivec2(0), ivec2(size) - 1), 0);
  }
  const vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
  const vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
  const vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
  const vec2 w3 = f * f * (-0.5 + 0.5 * f);
  const vec2 w12 = w1 + w2;
  const vec2 p0 = (centre1 - 1.0) * one;
  const vec2 p3 = (centre1 + 2.0) * one;
  const vec2 p12 = (centre1 + w2 / w12) * one;
  const vec4 middle = textureLod(history, p12, 0.0);
  vec3 sum = middle.rgb * (w12.x * w12.y);
  sum += textureLod(history, vec2(p12.x, p0.y), 0.0).rgb * (w12.x * w0.y);
  sum += textureLod(history, vec2(p0.x, p12.y), 0.0).rgb * (w0.x * w12.y);
  sum += textureLod(history, vec2(p3.x, p12.y), 0.0).rgb * (w3.x * w12.y);
  sum += textureLod(history, vec2(p12.x, p3.y), 0.0).rgb * (w12.x * w3.y);
  const float weights = w12.x * w12.y + w12.x * w0.y + w0.x * w12.y + w3.x * w12.y + w12.x * w3.y;
  return vec4(sum / weights, middle.a);
}

void main() {
  const ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  const ivec2 size = imageSize(outputImage);
  if (any(greaterThanEqual(p, size))) return;
  const ivec2 last = size - 1;

  // 1. The sample and its neighbourhood's box; the nearest depth of the 5 and where it is.
  const vec4 centre = texelFetch(current, p, 0);
  const vec3 here = toYCoCg(centre.rgb);
  vec3 lo = here, hi = here;
  const float ownDepth = texelFetch(depthImage, p, 0).r;
  float nearest = ownDepth;
  ivec2 nearestAt = p;
  // The 4 neighbours sharing an edge (with the pixel, 5 of the 3x3: the corners cost llvmpipe
  // as much again, and the tighter box held a panning camera's edges better: 29% less edge
  // error than none against 11% with the 3x3, tests/temporal_aa_tests.cpp).
  const ivec2 steps[4] = ivec2[4](ivec2(-1, 0), ivec2(1, 0), ivec2(0, -1), ivec2(0, 1));
  for (int k = 0; k < 4; ++k) {
    const ivec2 q = clamp(p + steps[k], ivec2(0), last);
    const vec3 c = toYCoCg(texelFetch(current, q, 0).rgb);
    lo = min(lo, c);
    hi = max(hi, c);
    const float z = texelFetch(depthImage, q, 0).r;
    const bool nearer = z < nearest;
    nearest = nearer ? z : nearest;
    nearestAt = nearer ? q : nearestAt;
  }

  // 2. Reprojection: the nearest point's unjittered NDC (its sample lies at the pixel's centre
  // minus the jitter) to the previous frame's pixels, as a motion added to this pixel's.
  const vec2 sizeF = vec2(size);
  const vec2 unjittered = vec2(nearestAt) + 0.5 - push.jitter.xy;
  const vec4 ndc = vec4(unjittered * push.jitter.zw * 2.0 - 1.0, nearest, 1.0);
  const vec4 previous = push.reprojection * ndc;  // previous clip / this view depth
  const float ahead = previous.w > 1e-6 ? 1.0 : 0.0;  // in front of the previous camera
  const vec2 previousPixel = ((previous.xy / max(previous.w, 1e-6)) * 0.5 + 0.5) * sizeF;
  const vec2 motion = previousPixel - unjittered;
  const vec2 at = vec2(p) + 0.5 + motion;  // where this pixel's centre was, in history pixels
  const float inside = all(greaterThanEqual(at, vec2(0.0))) && all(lessThanEqual(at, sizeF)) ? 1.0 : 0.0;

  // 3. Disocclusion: the point was hidden then when every view depth of the history around
  // where it was is nearer than the depth it had then (something in front covered it). Only
  // that way: a history farther than the point (a surface that moved in front, or an edge's
  // coverage that the jitter changed) is for the clamp, not a rejection.
  const float expected = previous.w * viewDepth(nearest);
  // The 2x2 texels around `at` (those its bilinear read would mix).
  const ivec2 h = ivec2(floor(at - 0.5));
  float farthest = 0.0;
  for (int dy = 0; dy <= 1; ++dy) {
    for (int dx = 0; dx <= 1; ++dx) {
      const float then = texelFetch(historyDepth, clamp(h + ivec2(dx, dy), ivec2(0), last), 0).r;
      farthest = max(farthest, then);
    }
  }
  const float uncovered = farthest < (1.0 - push.limits.x) * expected ? 1.0 : 0.0;
  const float valid = push.params.z * ahead * inside * (1.0 - uncovered);

  // 4. Clamp and blend.
  const vec4 past = historyAt(at, sizeF);
  const vec3 clamped = clamp(past.rgb, lo, hi);
  // (Selected, not multiplied: a rejected history's texels take no part at all.)
  const bool kept = valid > 0.5;
  const float samples = kept ? min(past.a, 254.0) + 1.0 : 1.0;
  const vec3 blended = kept ? mix(clamped, here, max(1.0 / samples, push.params.w)) : here;

  // 5. Out. Without a history the frame's own pixel, as it was.
  imageStore(outputImage, p, vec4(toSrgb(kept ? fromYCoCg(blended) : centre.rgb), centre.a));
  imageStore(nextHistory, p, vec4(blended, samples));
  imageStore(nextDepth, p, vec4(viewDepth(ownDepth), 0.0, 0.0, 0.0));
}
