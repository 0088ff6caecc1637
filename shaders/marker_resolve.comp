#version 450
#extension GL_GOOGLE_include_directive : require
// Light markers, step 2: one thread per pixel turns the strongest marker key (marker_splat.comp)
// into an emissive glow over the lit HDR image: the light's hue, whitening towards the centre,
// blended by the falloff times an opacity that fades as markers shrink with the light count.
// Divided by exposure so a marker looks the same at any exposure.
#include "frame.glsl"
#include "markers.glsl"

layout(local_size_x = MYRIAD_MARKER_GROUP, local_size_y = MYRIAD_MARKER_GROUP) in;

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_HDR_STORAGE, rgba16f) uniform image2D hdrImage;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, ivec2(frame.viewport.xy)))) return;
  uint key = imageLoad(markerKeys, p).r;
  if (key == 0u) return;
  uint index = (key & ((1u << MYRIAD_MARKER_INDEX_BITS) - 1u)) - 1u;
  float w = float(key >> MYRIAD_MARKER_INDEX_BITS) / 255.0;
  vec3 radiance = lights[index].radianceFalloff.rgb;
  float peak = max(radiance.r, max(radiance.g, radiance.b));
  vec3 hue = peak > 0.0 ? radiance / peak : vec3(0.0);
  vec3 glow = mix(hue, vec3(1.0), 0.35 * w * w) / frame.camera.x;
  vec4 lit = imageLoad(hdrImage, p);
  imageStore(hdrImage, p, vec4(mix(lit.rgb, glow, markerOpacity() * w), lit.a));
}
