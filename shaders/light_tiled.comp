#version 450
#extension GL_GOOGLE_include_directive : require
// Tiled deferred lighting (Andersson 2011; Lauritzen 2010) in one dispatch: each 16x16 workgroup
// finds its tile's depth range, culls every light against the tile's frustum into shared memory,
// then shades its pixels (sun + ambient + the tile's lights) into the HDR target; a tile with
// more lights than its list holds shades them a full list at a time, dropping none.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_TILE_SIZE, local_size_y = MYRIAD_TILE_SIZE) in;

shared uint tileMinDepthBits;
shared uint tileMaxDepthBits;
shared uint tileLightCount;  // in tileLights now
shared uint tileLightTotal;  // culled into the tile's lists so far
shared uint tileLights[MYRIAD_TILE_MAX_LIGHTS];
#if MYRIAD_TILE_MAX_LIGHTS < MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE
#error "a tile's list must hold at least one batch of lights (one per invocation)"
#endif

// Direction through an NDC point in view space (the camera looks down -z).
vec3 viewRay(vec2 ndc) {
  // (projection[2].xy: a jittered projection's offset, TAA's sub-frames; 0 otherwise.)
  return vec3((ndc.x + frame.projection[2][0]) / frame.projection[0][0],
              (ndc.y + frame.projection[2][1]) / frame.projection[1][1], -1.0);
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint local = gl_LocalInvocationIndex;
  bool onScreen = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  if (local == 0) {
    tileMinDepthBits = floatBitsToUint(1.0);
    tileMaxDepthBits = 0u;
    tileLightCount = 0u;
    tileLightTotal = 0u;
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

  // Lights are culled 256 at a time (one per invocation) into the tile's list; before a batch
  // that might not fit, the list so far is shaded and emptied, so a tile of any light count
  // drops none: its pixels add up every light that reaches them, a list at a time.
  const uint kBatch = MYRIAD_TILE_SIZE * MYRIAD_TILE_SIZE;
  uint lightCount = frame.flags.y;
  vec3 color = onScreen ? backgroundRadiance(pixel) : vec3(0.0);
  if (hasSurface) color = sunAndAmbient(s);
  uint reached = 0u;
  for (uint base = 0u; base < lightCount; base += kBatch) {
    uint index = base + local;
    if (tileHasSurface && index < lightCount) {
      vec4 light = lights[index].positionRadius;
      vec3 c = (frame.view * vec4(light.xyz, 1.0)).xyz;
      float r = light.w;
      // Conservative: a sphere touching the tile's frustum between its depths is kept.
      bool inside = -c.z + r > zNear && -c.z - r < zFar;
      for (int i = 0; i < 4; ++i) inside = inside && dot(planes[i], c) > -r;
      if (inside) tileLights[atomicAdd(tileLightCount, 1u)] = index;
    }
    barrier();
    // The same for every invocation: read between two barriers (the next batch adds to it).
    uint listed = tileLightCount;
    barrier();
    if (base + kBatch >= lightCount || listed + kBatch > MYRIAD_TILE_MAX_LIGHTS) {
      if (hasSurface) {
        for (uint i = 0u; i < listed; ++i) {
          uint light = tileLights[i];
          if (lightReaches(s, light)) {
            color += shadeLight(s, light);
            ++reached;
          }
        }
      }
      barrier();  // every invocation has read the list before it is emptied
      if (local == 0u) {
        tileLightTotal += listed;
        tileLightCount = 0u;
      }
      barrier();
    }
  }

  if (local == 0u && tileHasSurface) atomicMax(stats.totals.z, tileLightTotal);
  if (!onScreen) return;
  if (hasSurface) color = withLocalShadows(s, color);
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
