#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 4b (techniques/clustered.cpp, on by default where the subgroup shade pass runs;
// MYRIAD_CLUSTER_NARROW=0|1 overrides it): a workgroup per cluster tile shortens each of its
// clusters' lists, in place, to the lights whose sphere overlaps the world-space bounds of the
// cluster's own surface points. Assignment tests a light against the cluster's whole view box
// (its screen tile between the slice's depths); on a floor seen at a slant that box is metres
// thick while the points are a flat patch, so most of its lights float above the points out of
// reach. The shade pass's 16 tiles under the cluster then each narrow the short list instead of
// the long one (clustered_tile_narrow.glsl).
//
// The test is conservative (the box is widened by far more than rounding), so every light
// reaching a point of the cluster stays in its list: images and light counts are unchanged. The
// lists only serve the opaque surfaces' shading then: the technique skips this pass in frames
// with alpha-blended draws, whose surfaces are not in the depth target but read these lists.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = 256) in;

const uint kThreads = 256u;
const uint kSlices = MYRIAD_CLUSTER_SLICES;  // the grid's (render/cluster_grid.h)
const uint kNoRun = 0xFFFFFFFFu;

// Per slice: the points' bounds as orderedBits (lo starts at all ones, hi at 0: none yet).
shared uint worldLo[3u * kSlices];
shared uint worldHi[3u * kSlices];
shared uint kept;  // the lights kept so far of the slice being narrowed

// A float's bits mapped so that unsigned order is the floats' order (negatives reversed).
uint orderedBits(float f) {
  uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float fromOrderedBits(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7FFFFFFFu : ~u);
}

// Adds the box [lo, hi] to slice k's bounds.
void addBounds(uint k, vec3 lo, vec3 hi) {
  for (uint a = 0u; a < 3u; ++a) {
    atomicMin(worldLo[3u * k + a], orderedBits(lo[a]));
    atomicMax(worldHi[3u * k + a], orderedBits(hi[a]));
  }
}

void main() {
  uint thread = gl_LocalInvocationIndex;
  for (uint i = thread; i < 3u * kSlices; i += kThreads) {
    worldLo[i] = 0xFFFFFFFFu;
    worldHi[i] = 0u;
  }
  if (thread == 0u) kept = 0u;
  barrier();

  // Each invocation walks a column of the tile's pixels (rows apart by kThreads / size), keeping
  // the bounds of a run of pixels in one slice and adding them when the slice changes: a few
  // shared atomics per invocation, not six per pixel.
  uint size = clusterTileSize();
  uvec2 tile = gl_WorkGroupID.xy;
  uvec2 origin = tile * size;
  uint run = kNoRun;
  vec3 lo = vec3(0.0);
  vec3 hi = vec3(0.0);
  for (uint p = thread; p < size * size; p += kThreads) {
    ivec2 pixel = ivec2(origin + uvec2(p % size, p / size));
    if (pixel.x >= int(frame.viewport.x) || pixel.y >= int(frame.viewport.y)) continue;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth >= 1.0) continue;  // no surface (loadSurfaceWithDepth's test)
    uint k = sliceOfViewDepth(viewDepthFromDepth(depth));
    vec3 position = worldFromDepth(pixel, depth);
    if (k != run) {
      if (run < kSlices) addBounds(run, lo, hi);
      run = k;
      lo = position;
      hi = position;
    } else {
      lo = min(lo, position);
      hi = max(hi, position);
    }
  }
  if (run < kSlices) addBounds(run, lo, hi);
  barrier();

  // Each slice holding points: its cluster's list narrowed in place, a chunk of kThreads lights
  // at a time. Every invocation reads its light of the chunk before the barrier, and the kept
  // ones are written after it to slots below the chunk's end: no slot is written before it is
  // read. The loops' bounds read shared memory or buffers after a barrier, so every invocation
  // takes the same path through the barriers.
  for (uint k = 0u; k < kSlices; ++k) {
    if (worldHi[3u * k] == 0u) continue;  // no point in this slice
    uint cluster = clusterIndex(uvec3(tile, k));
    uvec2 range = clusterRanges[cluster];
    if (range.y == 0u) continue;
    // The points' own bounds: a light reaching one of them (|light - point|^2 < radius^2,
    // rounded) overlaps them widened by 1e-5 of the coordinates' size, far more than rounding
    // (the shade pass's narrowing widens its boxes so too).
    vec3 boxLo = vec3(fromOrderedBits(worldLo[3u * k]), fromOrderedBits(worldLo[3u * k + 1u]),
                      fromOrderedBits(worldLo[3u * k + 2u]));
    vec3 boxHi = vec3(fromOrderedBits(worldHi[3u * k]), fromOrderedBits(worldHi[3u * k + 1u]),
                      fromOrderedBits(worldHi[3u * k + 2u]));
    vec3 margin = 1e-5 * (max(abs(boxLo), abs(boxHi)) + vec3(1.0));
    boxLo -= margin;
    boxHi += margin;
    for (uint base = 0u; base < range.y; base += kThreads) {
      uint i = base + thread;
      uint index = 0u;
      bool keep = false;
      if (i < range.y) {
        index = clusterLights[range.x + i];
        vec4 light = lights[index].positionRadius;
        keep = sphereOverlapsBox(light.xyz, light.w, boxLo, boxHi);
      }
      memoryBarrierBuffer();
      barrier();
      if (keep) clusterLights[range.x + atomicAdd(kept, 1u)] = index;
      memoryBarrierBuffer();
      barrier();
    }
    barrier();
    if (thread == 0u) {
      clusterRanges[cluster].y = kept;
      kept = 0u;
    }
    barrier();
  }
}
