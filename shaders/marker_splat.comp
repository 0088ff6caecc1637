#version 450
#extension GL_GOOGLE_include_directive : require
// Light markers, step 1: one thread per light projects its centre and, where the kept G-buffer
// depth does not hide it (LESS_OR_EQUAL, as the old raster markers), offers a key (markers.h) to
// each pixel of a small disc of fixed pixel radius (markers.glsl). No raster, no blending: the
// cost is one projection per light plus at most 8x8 atomics, whatever the light's distance.
#include "frame.glsl"
#include "markers.glsl"

layout(local_size_x = MYRIAD_LIGHTS_PER_GROUP) in;

// PCG-style integer hash (Jarzynski & Olano, JCGT 2020) -> [0, 1): which lights keep a marker.
float markerHash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return float((word >> 22u) ^ word) / 4294967296.0;
}

void main() {
  uint index = gl_GlobalInvocationID.x;
  if (index >= frame.flags.y) return;
  if (markerHash(index) >= markerKeep()) return;
  vec4 clip = frame.viewProjection * vec4(lights[index].positionRadius.xyz, 1.0);
  if (clip.w <= 0.0) return;  // behind the camera
  vec3 ndc = clip.xyz / clip.w;
  if (ndc.z < 0.0 || ndc.z > 1.0 || abs(ndc.x) > 1.01 || abs(ndc.y) > 1.01) return;
  vec2 centre = (ndc.xy * 0.5 + 0.5) * frame.viewport.xy;  // in pixels, y down like the image
  ivec2 size = ivec2(frame.viewport.xy);
  float radius = markerRadius();
  uint id = index + 1u;
  if (radius < kMarkerMinRadius) {
    // One pixel: the one that holds the centre, at full weight.
    ivec2 p = ivec2(floor(centre));
    if (any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size))) return;
    if (ndc.z > texelFetch(gbufferDepth, p, 0).r) return;
    imageAtomicMax(markerKeys, p, (255u << MYRIAD_MARKER_INDEX_BITS) | id);
    return;
  }
  int reach = int(ceil(radius));
  ivec2 first = max(ivec2(floor(centre)) - reach, ivec2(0));
  ivec2 last = min(ivec2(floor(centre)) + reach, size - 1);
  for (int y = first.y; y <= last.y; ++y) {
    for (int x = first.x; x <= last.x; ++x) {
      vec2 d = (vec2(x, y) + 0.5 - centre) / radius;
      float q = dot(d, d);
      if (q >= 1.0) continue;
      if (ndc.z > texelFetch(gbufferDepth, ivec2(x, y), 0).r) continue;
      // Soft round falloff: 1 at the centre, 0 with zero slope at the rim.
      uint weight = uint((1.0 - q) * (1.0 - q) * 255.0 + 0.5);
      if (weight == 0u) continue;
      imageAtomicMax(markerKeys, ivec2(x, y), (weight << MYRIAD_MARKER_INDEX_BITS) | id);
    }
  }
}
