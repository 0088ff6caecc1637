// The final pass (final.comp, final_raw.comp): the `final` view, and the picture under the
// light-volumes view's overlay. One thread per pixel: the lit HDR value, the light marker that
// marker_splat.comp chose for the pixel blended in (its resolve), then, for an 8-bit image,
// exposure, Khronos PBR Neutral and sRGB encoding. With anti-aliasing on, the encoded colour and
// its luma go to the LDR target for antialias.comp, and the pixel itself to the output unless it
// is on an edge (antialias.glsl), where it is listed for antialias.comp instead. Raw output gets
// the HDR values themselves (markers included), never anti-aliased.
#include "frame.glsl"
#include "markers.glsl"

#ifdef MYRIAD_FINAL_CPU
#define FINAL_GROUP MYRIAD_FINAL_CPU_GROUP
#else
#define FINAL_GROUP MYRIAD_PIXEL_GROUP
#endif
layout(local_size_x = FINAL_GROUP, local_size_y = FINAL_GROUP) in;

#ifdef MYRIAD_FINAL_CPU
// CPU devices: the parts this pipeline runs, fixed when it is made (shared_types.h says why).
layout(constant_id = MYRIAD_SPEC_FINAL_PARTS) const uint kFinalParts =
    MYRIAD_FINAL_ANTIALIAS | MYRIAD_FINAL_MARKERS;
bool markersOn() { return (kFinalParts & MYRIAD_FINAL_MARKERS) != 0u; }
bool antialiasOn() { return (kFinalParts & MYRIAD_FINAL_ANTIALIAS) != 0u; }
#else
bool markersOn() { return frame.post.y != 0u; }
bool antialiasOn() { return frame.post.x != MYRIAD_ANTIALIAS_NONE; }
#endif

#ifdef MYRIAD_RAW_OUTPUT
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba32f) uniform writeonly image2D outputImage;
#else
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_OUTPUT, rgba8) uniform writeonly image2D outputImage;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_LDR_STORAGE, rgba8) uniform writeonly image2D ldrImage;
#endif

// The marker at `pixel` over the lit value: the light's hue (its radiance over its largest
// channel), whiter towards the centre, blended by the falloff weight times an opacity that fades
// as markers shrink with the light count. Divided by exposure so a marker looks the same at any
// exposure.
vec3 withMarker(ivec2 pixel, vec3 lit) {
  uint key = imageLoad(markerKeys, pixel).r;
  if (key == 0u) return lit;
  uint index = (key & ((1u << MYRIAD_MARKER_INDEX_BITS) - 1u)) - 1u;
  float w = float(key >> MYRIAD_MARKER_INDEX_BITS) / 255.0;
  vec3 radiance = lights[index].radianceFalloff.rgb;
  float peak = max(radiance.r, max(radiance.g, radiance.b));
  vec3 hue = peak > 0.0 ? radiance / peak : vec3(0.0);
  vec3 glow = mix(hue, vec3(1.0), 0.35 * w * w) / frame.camera.x;
  return mix(lit, glow, markerOpacity() * w);
}

#ifdef MYRIAD_RAW_OUTPUT
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  vec3 hdr = texelFetch(hdrColor, pixel, 0).rgb;
  if (frame.post.y != 0u) hdr = withMarker(pixel, hdr);
  imageStore(outputImage, pixel, vec4(hdr, 1.0));
}
#else
#include "antialias.glsl"

#ifdef MYRIAD_FINAL_CPU
// srgbEncode (shading.glsl) without pow, which llvmpipe computes as exp2(log2) with two
// polynomials and a division: above the linear segment, the curve as a degree-5 polynomial of
// c^(1/8) (three square roots) on [0.0031308^(1/8), 1], fitted at Chebyshev nodes. Evaluated
// in float it is within 4.5e-7 of the exact curve (the float rounding of pow's own result is
// 6e-8), so the 8-bit code differs from the exact curve's for about 1 value in 20,000, as a
// float pow's does near the same boundaries.
vec3 srgbEncodeCpu(vec3 linear) {
  vec3 c = clamp(linear, 0.0, 1.0);
  vec3 s = (sqrt(sqrt(sqrt(c))) - 0.74317950) * 3.8937697;
  vec3 curve = ((((-3.7850339e-05 * s + 8.1117032e-04) * s + 2.7978225e-02) * s + 1.8216187e-01) * s +
                4.5183468e-01) * s + 3.3725181e-01;
  return mix(curve, 12.92 * c, lessThanEqual(c, vec3(0.0031308)));
}
#define srgbEncode3 srgbEncodeCpu
#endif

// The 8-bit colour of `pixel`: exposure, PBR Neutral, sRGB encoding, marker blended in.
vec3 encodedColor(ivec2 pixel) {
  vec3 hdr = texelFetch(hdrColor, pixel, 0).rgb;
  if (markersOn()) hdr = withMarker(pixel, hdr);
  vec3 color = srgbEncode3(tonemapPbrNeutral(hdr * frame.camera.x));
  // The light-volumes view dims the picture so the overlay drawn next stands out.
  if (frame.flags.x == MYRIAD_VIEW_LIGHT_VOLUMES) color *= 0.5;
  return color;
}

#ifdef MYRIAD_FINAL_CPU
// CPU devices: one pixel each, no shared memory and no workgroup barrier (llvmpipe reads and
// writes shared memory one lane and one component at a time, and splits the shader at a barrier):
// with anti-aliasing the encoded colour and its luma go to the LDR target only, and
// antialias_edges.comp tests the edges from there and writes the pixels off them. 26 -> 9 ms
// (final) + 5 (edges) at 1280x720 on the built-in scene; the same image.
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  vec3 c = encodedColor(pixel);
  if (antialiasOn()) {
    imageStore(ldrImage, pixel, vec4(c, perceivedLuma(c)));
  } else {
    imageStore(outputImage, pixel, vec4(c, 1.0));
  }
}
#else
// With anti-aliasing: the group's pixels and a one-pixel border, encoded once each (rgb, luma).
const int kTileSide = FINAL_GROUP + 2;
shared vec4 tile[kTileSide * kTileSide];
shared uint groupEdges;  // edge pixels of this group, then (groupBase) where they go in the list
shared uint groupBase;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  bool inside = all(lessThan(pixel, ivec2(frame.viewport.xy)));
  if (!antialiasOn()) {  // the same for the whole dispatch
    if (inside) imageStore(outputImage, pixel, vec4(encodedColor(pixel), 1.0));
    return;
  }
  ivec2 last = ivec2(frame.viewport.xy) - 1;
  ivec2 origin = ivec2(gl_WorkGroupID.xy) * FINAL_GROUP - 1;
  for (int i = int(gl_LocalInvocationIndex); i < kTileSide * kTileSide;
       i += FINAL_GROUP * FINAL_GROUP) {
    vec3 c = encodedColor(clamp(origin + ivec2(i % kTileSide, i / kTileSide), ivec2(0), last));
    tile[i] = vec4(c, perceivedLuma(c));
  }
  if (gl_LocalInvocationIndex == 0u) groupEdges = 0u;
  barrier();

  // The edge test of antialias.comp's first step, on the pixel's cross; pixels off an edge are
  // final here, the others are listed for it (and every pixel's colour and luma go to the LDR
  // target, which its edge walk reads).
  int at = (int(gl_LocalInvocationID.y) + 1) * kTileSide + int(gl_LocalInvocationID.x) + 1;
  vec4 centre = tile[at];
  bool edge = false;
  uint slot = 0u;
  if (inside) {
    imageStore(ldrImage, pixel, centre);
    float up = tile[at - kTileSide].a;
    float down = tile[at + kTileSide].a;
    float left = tile[at - 1].a;
    float right = tile[at + 1].a;
    float lowest = min(centre.a, min(min(up, down), min(left, right)));
    float highest = max(centre.a, max(max(up, down), max(left, right)));
    edge = onEdge(lowest, highest);
    if (edge) {
      slot = atomicAdd(groupEdges, 1u);
    } else {
      imageStore(outputImage, pixel, vec4(centre.rgb, 1.0));
    }
  }
  barrier();
  // One global atomic per group with edges; the dispatch's group count follows the list.
  if (gl_LocalInvocationIndex == 0u && groupEdges > 0u) {
    groupBase = atomicAdd(edges.count.x, groupEdges);
    atomicMax(edges.groups.x,
              (groupBase + groupEdges + MYRIAD_EDGES_PER_GROUP - 1u) / MYRIAD_EDGES_PER_GROUP);
  }
  barrier();
  if (edge) edgePixels[groupBase + slot] = packEdgePixel(pixel);
}
#endif  // MYRIAD_FINAL_CPU
#endif
