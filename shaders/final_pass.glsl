// The final pass (final.comp, final_raw.comp): the `final` view, and the picture under the
// light-volumes view's overlay. One thread per pixel: the lit HDR value, the light marker that
// marker_splat.comp chose for the pixel blended in (its resolve), then, for an 8-bit image,
// exposure, Khronos PBR Neutral and sRGB encoding. With anti-aliasing on, the encoded colour and
// its luma go to the LDR target for antialias.comp instead of the output. Raw output gets the HDR
// values themselves (markers included), never anti-aliased.
#include "frame.glsl"
#include "markers.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

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

// Luma of an sRGB-encoded colour (Rec. 601 weights): what the anti-aliasing pass compares. Gamma
// space on purpose: a step is judged by how it looks, not by its linear energy.
float perceivedLuma(vec3 encoded) {
  return dot(encoded, vec3(0.299, 0.587, 0.114));
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  vec3 hdr = texelFetch(hdrColor, pixel, 0).rgb;
  if (frame.post.y != 0u) hdr = withMarker(pixel, hdr);
#ifdef MYRIAD_RAW_OUTPUT
  imageStore(outputImage, pixel, vec4(hdr, 1.0));
#else
  vec3 color = srgbEncode3(tonemapPbrNeutral(hdr * frame.camera.x));
  // The light-volumes view dims the picture so the overlay drawn next stands out.
  if (frame.flags.x == MYRIAD_VIEW_LIGHT_VOLUMES) color *= 0.5;
  if (frame.post.x == MYRIAD_ANTIALIAS_NONE) {
    imageStore(outputImage, pixel, vec4(color, 1.0));
  } else {
    imageStore(ldrImage, pixel, vec4(color, perceivedLuma(color)));
  }
#endif
}
