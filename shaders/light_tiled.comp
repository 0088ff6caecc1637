#version 450
#extension GL_GOOGLE_include_directive : require
// Tiled deferred lighting (Andersson 2011; Lauritzen 2010) in one dispatch: each 16x16 workgroup
// finds its tile's depth range, culls every light against the tile's frustum into shared memory,
// then shades its pixels (sun + ambient + the tile's lights) into the HDR target.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_TILE_SIZE, local_size_y = MYRIAD_TILE_SIZE) in;

shared uint tileMinDepthBits;
shared uint tileMaxDepthBits;
shared uint tileLightCount;
shared uint tileLights[MYRIAD_TILE_MAX_LIGHTS];

// Direction through an NDC point in view space (the camera looks down -z).
vec3 viewRay(vec2 ndc) {
  return vec3(ndc.x / frame.projection[0][0], ndc.y / frame.projection[1][1], -1.0);
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint local = gl_LocalInvocationIndex;
  bool onScreen = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  if (local == 0) {
    tileMinDepthBits = floatBitsToUint(1.0);
    tileMaxDepthBits = 0u;
    tileLightCount = 0u;
  }
  barrier();

  float depth = onScreen ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
  Surface s;
  bool hasSurface = onScreen && loadSurfaceWithDepth(pixel, depth, s);
  // Non-negative floats order like their bit patterns, so integer atomics find the range.
  if (hasSurface) {
    atomicMin(tileMinDepthBits, floatBitsToUint(depth));
    atomicMax(tileMaxDepthBits, floatBitsToUint(depth));
  }
  barrier();

  bool tileHasSurface = tileMaxDepthBits != 0u;
  float zNear = viewDepthFromDepth(uintBitsToFloat(tileMinDepthBits));
  float zFar = viewDepthFromDepth(uintBitsToFloat(tileMaxDepthBits));

  // The tile's four side planes through the eye, normals pointing into the tile.
  vec2 size = frame.viewport.xy;
  vec2 ndc0 = vec2(gl_WorkGroupID.xy * MYRIAD_TILE_SIZE) / size * 2.0 - 1.0;
  vec2 ndc1 = vec2(min((gl_WorkGroupID.xy + 1u) * MYRIAD_TILE_SIZE, uvec2(size))) / size * 2.0 - 1.0;
  vec3 c00 = viewRay(ndc0), c10 = viewRay(vec2(ndc1.x, ndc0.y));
  vec3 c11 = viewRay(ndc1), c01 = viewRay(vec2(ndc0.x, ndc1.y));
  vec3 centre = viewRay(0.5 * (ndc0 + ndc1));
  vec3 planes[4] = vec3[4](cross(c00, c10), cross(c10, c11), cross(c11, c01), cross(c01, c00));
  for (int i = 0; i < 4; ++i) {
    planes[i] = normalize(planes[i]);
    if (dot(planes[i], centre) < 0.0) planes[i] = -planes[i];
  }

  uint lightCount = frame.flags.y;
  for (uint base = 0u; base < lightCount; base += MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE) {
    uint index = base + local;
    if (tileHasSurface && index < lightCount) {
      vec4 light = lights[index].positionRadius;
      vec3 c = (frame.view * vec4(light.xyz, 1.0)).xyz;
      float r = light.w;
      // Conservative: a sphere touching the tile's frustum between its depths is kept.
      bool inside = -c.z + r > zNear && -c.z - r < zFar;
      for (int i = 0; i < 4; ++i) inside = inside && dot(planes[i], c) > -r;
      if (inside) {
        uint slot = atomicAdd(tileLightCount, 1u);
        if (slot < MYRIAD_TILE_MAX_LIGHTS) tileLights[slot] = index;
      }
    }
  }
  barrier();

  uint listed = min(tileLightCount, uint(MYRIAD_TILE_MAX_LIGHTS));
  if (local == 0 && tileHasSurface) {
    atomicMax(stats.totals.z, tileLightCount);
    if (tileLightCount > MYRIAD_TILE_MAX_LIGHTS) {
      atomicAdd(stats.overflow.x, 1u);
      atomicAdd(stats.overflow.y, tileLightCount - MYRIAD_TILE_MAX_LIGHTS);
    }
  }
  if (!onScreen) return;
  vec3 color = backgroundRadiance(pixel);
  uint reached = 0u;
  if (hasSurface) {
    color = sunAndAmbient(s);
    for (uint i = 0u; i < listed; ++i) {
      uint index = tileLights[i];
      if (lightReaches(s, index)) {
        color += shadeLight(s, index);
        ++reached;
      }
    }
    color = withLocalShadows(s, color);
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
