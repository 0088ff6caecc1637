// The views pass (views.comp, views_raw.comp): every view of the frame but `final` and
// `light-volumes` (final_pass.glsl), one thread per pixel. For images (RGBA8_UNORM) it maps data
// views to [0,1] (sRGB-encoding albedo, tonemapping emissive); for raw output (RGBA32F) it writes
// the view's values themselves (see protocol reference, format=raw). Never anti-aliased: a data
// view's pixels are the target's own values.
#include "frame.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

#ifdef MYRIAD_RAW_OUTPUT
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba32f) uniform writeonly image2D outputImage;
const bool raw = true;
#else
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba8) uniform writeonly image2D outputImage;
const bool raw = false;
#endif

// --- light-count heat map and its scale ---------------------------------------------------

// Black -> blue -> cyan -> green -> yellow -> red -> white.
vec3 heatRamp(float t) {
  const vec3 stops[7] = vec3[7](vec3(0.0, 0.0, 0.0), vec3(0.1, 0.2, 0.9), vec3(0.0, 0.8, 0.9),
                                vec3(0.1, 0.85, 0.2), vec3(0.95, 0.9, 0.1), vec3(0.95, 0.15, 0.1),
                                vec3(1.0, 1.0, 1.0));
  float x = clamp(t, 0.0, 1.0) * 6.0;
  int i = min(int(x), 5);
  return mix(stops[i], stops[i + 1], x - float(i));
}

// 3x5 digits, rows top to bottom, 3 bits a row (left column = high bit).
const uint kDigits[10] = uint[10](31599u, 11415u, 29671u, 29647u, 23497u, 31183u, 31215u, 29257u,
                                  31727u, 31695u);

// Whether `pixel` is lit by `value` printed with its top-left corner at `origin`, `scale` pixels
// per font pixel.
bool printsNumber(ivec2 pixel, ivec2 origin, uint value, int scale) {
  uint digits = 1u;
  for (uint v = value; v >= 10u; v /= 10u) ++digits;
  ivec2 p = (pixel - origin) / scale;
  if (pixel.x < origin.x || pixel.y < origin.y || p.y >= 5 || p.x >= int(digits) * 4) return false;
  int column = p.x / 4;
  int x = p.x % 4;
  if (x == 3) return false;  // spacing between digits
  uint digit = value;
  for (int i = int(digits) - 1; i > column; --i) digit /= 10u;
  digit %= 10u;
  uint bit = 14u - uint(p.y * 3 + x);
  return ((kDigits[digit] >> bit) & 1u) != 0u;
}

// The heat map, with a colour bar labelled 0 .. max along the bottom-left corner.
vec3 lightCountView(ivec2 pixel, float count, bool hasSurface) {
  float maxCount = frame.slicing.z;
  ivec2 size = ivec2(frame.viewport.xy);
  int scale = size.x >= 480 ? 2 : 1;
  int barLeft = 6 * scale, barRight = min(size.x - 6 * scale, 160 * scale);
  int barBottom = size.y - 4 * scale, barTop = barBottom - 6 * scale;
  int labelTop = barTop - 7 * scale;
  if (size.x >= 64 && size.y >= 48 && pixel.x >= barLeft - scale && pixel.x <= barRight + scale &&
      pixel.y >= labelTop - scale && pixel.y <= barBottom + scale) {
    if (pixel.y >= barTop && pixel.y < barBottom && pixel.x >= barLeft && pixel.x < barRight) {
      return heatRamp(float(pixel.x - barLeft) / float(barRight - barLeft));
    }
    uint maxLabel = uint(maxCount);
    uint maxDigits = 1u;
    for (uint v = maxLabel; v >= 10u; v /= 10u) ++maxDigits;
    ivec2 maxOrigin = ivec2(barRight - int(maxDigits) * 4 * scale + scale, labelTop);
    if (printsNumber(pixel, ivec2(barLeft, labelTop), 0u, scale) ||
        printsNumber(pixel, maxOrigin, maxLabel, scale)) {
      return vec3(1.0);
    }
    return vec3(0.0);  // a dark backing so the scale reads on any picture
  }
  if (!hasSurface) return vec3(0.0);
  return count == 0.0 ? vec3(0.04) : heatRamp(0.1 + 0.9 * count / maxCount);
}

// --- clusters --------------------------------------------------------------------------------

vec3 sliceColor(uint slice) {
  float hue = fract(float(slice) * 0.618034);
  vec3 rgb = clamp(abs(fract(hue + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0);
  return mix(vec3(0.3), rgb, 0.75);
}


// The `shadow` view: the sun's shadow factor as the lighting computes it, and the cascade it read.
// Its own pipelines (kShadowView): inside the others' branch on the view, lavapipe (Mesa 22.3)
// found that fixing the view removed half the shader, and compiled it again at every bind
// (frame.glsl's sunShadowCascade tells the rest).
layout(constant_id = MYRIAD_SPEC_SHADOW_VIEW) const bool kShadowView = false;
vec4 shadowViewValue(ivec2 pixel, float depth, bool hasSurface) {
  if (!hasSurface) return raw ? vec4(1.0, -1.0, 0.0, 0.0) : vec4(0.0, 0.0, 0.0, 1.0);
  vec3 p = worldFromDepth(pixel, depth);
  vec3 n = octahedralDecode(texelFetch(gbufferNormal, pixel, 0).rg);
  int cascade = sunShadowCascade(p);
  float lit = sunShadowFactorIn(cascade, p, n);
  if (raw) return vec4(lit, float(cascade), 0.0, 0.0);
  const vec3 tints[4] = vec3[4](vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 0.0, 1.0),
                                vec3(1.0, 1.0, 0.0));
  vec3 tint = cascade < 0 ? vec3(1.0) : tints[min(cascade, 3)];
  return vec4(tint * lit, 1.0);
}

vec4 viewValue(ivec2 pixel) {
  uint view = frame.flags.x;
  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  bool hasSurface = depth < 1.0;
  if (kShadowView) return shadowViewValue(pixel, depth, hasSurface);

  if (view == MYRIAD_VIEW_LIGHT_COUNT) {
    float count = texelFetch(lightCount, pixel, 0).r;
    return raw ? vec4(count, 0.0, 0.0, 0.0) : vec4(lightCountView(pixel, count, hasSurface), 1.0);
  }
  if (view == MYRIAD_VIEW_DEPTH) {
    float n = frame.camera.y;
    float f = frame.camera.z;
    float z = hasSurface ? viewDepthFromDepth(depth) : f;
    return raw ? vec4(z, 0.0, 0.0, 0.0) : vec4(vec3(clamp((z - n) / (f - n), 0.0, 1.0)), 1.0);
  }
  if (!hasSurface) return vec4(0.0, 0.0, 0.0, raw ? 0.0 : 1.0);
  vec4 value = vec4(0.0, 0.0, 0.0, 1.0);
  if (view == MYRIAD_VIEW_ALBEDO) {
    vec3 albedo = texelFetch(gbufferBaseColor, pixel, 0).rgb;
    value.rgb = raw ? albedo : srgbEncode3(albedo);
  } else if (view == MYRIAD_VIEW_NORMAL) {
    vec3 n = octahedralDecode(texelFetch(gbufferNormal, pixel, 0).rg);
    value.rgb = raw ? n : n * 0.5 + 0.5;
  } else if (view == MYRIAD_VIEW_POSITION) {
    vec3 p = worldFromDepth(pixel, depth);
    vec3 extent = max(frame.boundsMax.xyz - frame.boundsMin.xyz, vec3(1e-6));
    value.rgb = raw ? p : clamp((p - frame.boundsMin.xyz) / extent, 0.0, 1.0);
  } else if (view == MYRIAD_VIEW_UV) {
    vec2 uv = texelFetch(gbufferUv, pixel, 0).rg;
    value.rgb = raw ? vec3(uv, 0.0) : vec3(fract(uv), 0.0);
  } else if (view == MYRIAD_VIEW_METALLIC) {
    value.rgb = vec3(texelFetch(gbufferMaterial, pixel, 0).r);
  } else if (view == MYRIAD_VIEW_ROUGHNESS) {
    value.rgb = vec3(texelFetch(gbufferMaterial, pixel, 0).g);
  } else if (view == MYRIAD_VIEW_OCCLUSION) {
    value.rgb = vec3(texelFetch(gbufferMaterial, pixel, 0).b);
  } else if (view == MYRIAD_VIEW_EMISSIVE) {
    vec3 emitted = texelFetch(gbufferEmissive, pixel, 0).rgb;
    value.rgb = raw ? emitted : srgbEncode3(tonemapPbrNeutral(emitted * frame.camera.x));
  } else if (view == MYRIAD_VIEW_CLUSTERS) {
    uint slice = sliceOfViewDepth(viewDepthFromDepth(depth));
    uvec2 tile = uvec2(pixel) / clusterTileSize();
    float checker = ((tile.x + tile.y) & 1u) == 0u ? 1.0 : 0.8;
    value.rgb = raw ? vec3(float(slice), float(tile.x), float(tile.y)) : sliceColor(slice) * checker;
  }
  return value;
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  imageStore(outputImage, pixel, viewValue(pixel));
}
