// Clustered step 5, the body of light_clustered*.comp: each pixel shades sun + ambient + the
// lights of its cluster's list.
//
// A 64x64-pixel cluster's list holds every light overlapping the whole frustum segment; with a
// million small lights that is thousands of lights of which a pixel's few dozen reach it. So each
// MYRIAD_CLUSTER_SHADE_TILE-square workgroup first narrows the lists of the clusters its pixels
// fall in to the lights whose sphere overlaps the world-space box around its own pixels' surface
// points in that slice (on a floor seen at a grazing angle a flat box, where the box of the
// tile's frustum segment between its nearest and farthest depth was metres deep). The narrowed
// lists live in shared memory, one segment per slice.
//
// Then either each pixel walks its slice's segment (MYRIAD_CLUSTER_SUBGROUP_WALK undefined), or
// (defined; needs subgroup ballot and arithmetic in compute) each subgroup walks it together: a
// subgroup of pixels (an 8x4 block with 32 lanes: invocations follow Morton order in the tile)
// tests the segment's lights one per lane against the box of its own surface points, and only
// the lights of that ballot are tested by every pixel and shaded. The loop over the ballot is
// uniform in the subgroup, so a light none of its pixels reaches costs one lane one box test.
//
// Every test is conservative (the boxes are widened by far more than rounding) and each pixel
// still decides every light exactly (lightReaches), so the image and the light counts are those
// of the whole list. A tile whose narrowed lists overflow the shared capacity, or whose pixels
// span more than MYRIAD_CLUSTER_TILE_SLICES slices, walks the whole list there (the subgroup
// walk narrows that list to its own box as it goes).
#include "frame.glsl"
#include "compute_targets.glsl"

#ifndef MYRIAD_SHADE_TILE  // an experiment's tile size, else the shipped one
#define MYRIAD_SHADE_TILE MYRIAD_CLUSTER_SHADE_TILE
#define MYRIAD_SHADE_TILE_LIGHTS MYRIAD_CLUSTER_TILE_LIGHTS
#endif

#ifdef MYRIAD_CLUSTER_SUBGROUP_WALK  // the includer enables the GL_KHR_shader_subgroup_* it uses
layout(local_size_x = MYRIAD_SHADE_TILE * MYRIAD_SHADE_TILE) in;
#else
layout(local_size_x = MYRIAD_SHADE_TILE, local_size_y = MYRIAD_SHADE_TILE) in;
#endif

const uint kThreads = MYRIAD_SHADE_TILE * MYRIAD_SHADE_TILE;
const uint kSlices = MYRIAD_CLUSTER_TILE_SLICES;
const uint kCapacity = MYRIAD_SHADE_TILE_LIGHTS;
const uint kWholeList = 0xFFFFFFFFu;  // a segment's length when its pixels walk the cluster's list
const uint kEmpty = 0xFFFFFFFFu;

shared uint tileLights[kCapacity];
shared uint firstSlice;
shared uint lastSlice;
// Per slice, the world-space box of the tile's surface points in it, as orderedBits (a min of
// kEmpty and a max of 0 while no point is in it).
shared uint boxLo[kSlices][3];
shared uint boxHi[kSlices][3];
shared uint used;
shared uint nextStart;  // where the next slice's segment starts (thread 0 keeps it)
shared uint segmentStart[kSlices];
shared uint segmentLength[kSlices];

#ifdef MYRIAD_CLUSTER_PREPARED
#define MYRIAD_SHADE(index) shadeLightAt(brdf, s, index)
#else
#define MYRIAD_SHADE(index) shadeLight(s, index)
#endif

#ifdef MYRIAD_CLUSTER_QUEUE
// Each pixel queues the lights that reach it (in list order) and the subgroup shades the queues
// together when one is full: kQueue shading steps for the subgroup, in which most lanes work,
// where shading each light of the subgroup's ballot idles the lanes it does not reach.
const uint kQueue = 16u;
shared uint queue[kQueue * kThreads];

void flushQueue(Surface s, BrdfSurface brdf, uint thread, inout vec3 color, inout uint queued) {
  uint most = subgroupMax(queued);
  for (uint m = 0u; m < most; ++m) {
    if (m < queued) color += MYRIAD_SHADE(queue[m * kThreads + thread]);
  }
  queued = 0u;
}
#endif

// A float's bits as a uint that orders as the float does (negative values flipped).
uint orderedBits(float f) {
  uint b = floatBitsToUint(f);
  return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}

float fromOrderedBits(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7FFFFFFFu) : ~u);
}

// A box around surface points, widened so that a light reaching one of them (lightReaches:
// |light - point|^2 < radius^2, rounded) always overlaps it (sphereOverlapsBox, rounded):
// 1e-5 of the coordinates' size is far more than either test's rounding.
void widenBox(inout vec3 lo, inout vec3 hi) {
  vec3 margin = 1e-5 * (max(abs(lo), abs(hi)) + vec3(1.0));
  lo -= margin;
  hi += margin;
}

void main() {
#ifdef MYRIAD_CLUSTER_SUBGROUP_WALK
  // Morton order inside the tile: a subgroup of 32 invocations is an 8x4 block, of 8 a 4x2 one.
  uint thread = gl_LocalInvocationIndex;
  uvec2 inTile = uvec2(0u);
  for (uint b = 0u; (1u << b) < kThreads; ++b) {
    uint bit = (thread >> b) & 1u;
    if ((b & 1u) == 0u) {
      inTile.x |= bit << (b >> 1u);
    } else {
      inTile.y |= bit << (b >> 1u);
    }
  }
  ivec2 pixel = ivec2(gl_WorkGroupID.xy * MYRIAD_SHADE_TILE + inTile);
#else
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint thread = gl_LocalInvocationIndex;
#endif
  bool inside = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  float depth = inside ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
  Surface s;
  bool surface = inside && loadSurfaceWithDepth(pixel, depth, s);
  uint slice = sliceOfViewDepth(viewDepthFromDepth(depth));

#ifndef MYRIAD_CLUSTER_DIRECT
  if (thread == 0u) {
    firstSlice = kEmpty;
    lastSlice = 0u;
    used = 0u;
    nextStart = 0u;
  }
  if (thread < kSlices) {
    for (uint a = 0u; a < 3u; ++a) {
      boxLo[thread][a] = kEmpty;
      boxHi[thread][a] = 0u;
    }
  }
  barrier();
  if (surface) {
    atomicMin(firstSlice, slice);
    atomicMax(lastSlice, slice);
  }
  barrier();
  uint k = slice - firstSlice;  // this pixel's segment
  bool boxed = surface && k < kSlices;
  uvec3 lo3 = uvec3(orderedBits(s.position.x), orderedBits(s.position.y), orderedBits(s.position.z));
#ifdef MYRIAD_CLUSTER_SUBGROUP_WALK
  // One lane adds its subgroup's box when all its boxed lanes share a slice (nearly always).
  uint subgroupSlice = subgroupMin(boxed ? k : kEmpty);
  if (subgroupAll(!boxed || k == subgroupSlice)) {
    uvec3 lo = subgroupMin(boxed ? lo3 : uvec3(kEmpty));
    uvec3 hi = subgroupMax(boxed ? lo3 : uvec3(0u));
    if (subgroupElect() && subgroupSlice != kEmpty) {
      for (uint a = 0u; a < 3u; ++a) {
        atomicMin(boxLo[subgroupSlice][a], lo[a]);
        atomicMax(boxHi[subgroupSlice][a], hi[a]);
      }
    }
    boxed = false;
  }
#endif
  if (boxed) {
    for (uint a = 0u; a < 3u; ++a) {
      atomicMin(boxLo[k][a], lo3[a]);
      atomicMax(boxHi[k][a], lo3[a]);
    }
  }
  barrier();

  // Narrow each occupied slice's list in turn, over the tile's span of slices only. The loop's
  // bound and conditions read shared memory after a barrier, so every invocation takes the same
  // path through the two barriers inside (on lavapipe each barrier switches all the workgroup's
  // invocations: walking all kSlices with three barriers each was half the pass's time).
  uvec2 tile = gl_WorkGroupID.xy * MYRIAD_SHADE_TILE / clusterTileSize();
  uint span = firstSlice == kEmpty ? 0u : min(lastSlice - firstSlice + 1u, kSlices);
  for (uint j = 0u; j < span; ++j) {
    if (boxLo[j][0] == kEmpty) continue;
    uvec2 range = clusterRanges[clusterIndex(uvec3(tile, firstSlice + j))];
    vec3 lo = vec3(fromOrderedBits(boxLo[j][0]), fromOrderedBits(boxLo[j][1]), fromOrderedBits(boxLo[j][2]));
    vec3 hi = vec3(fromOrderedBits(boxHi[j][0]), fromOrderedBits(boxHi[j][1]), fromOrderedBits(boxHi[j][2]));
    widenBox(lo, hi);
    for (uint i = thread; i < range.y; i += kThreads) {
      uint index = clusterLights[range.x + i];
      vec4 light = lights[index].positionRadius;
      if (sphereOverlapsBox(light.xyz, light.w, lo, hi)) {
        uint slot = atomicAdd(used, 1u);
        if (slot < kCapacity) tileLights[slot] = index;
      }
    }
    barrier();
    if (thread == 0u) {
      uint start = nextStart;
      segmentStart[j] = start;
      if (used > kCapacity) {
        segmentLength[j] = kWholeList;
        used = start;  // later slices may still fit
      } else {
        segmentLength[j] = used - start;
      }
      nextStart = used;
    }
    barrier();
  }
#endif

  vec3 color = vec3(0.0);
  uint reached = 0u;
  if (surface) color = sunAndAmbient(s);
#ifdef MYRIAD_CLUSTER_SUBGROUP_WALK
  // The list this pixel walks: its slice's segment (key < kSlices) or its cluster's whole list
  // (kSlices + cluster index). The subgroup walks its pixels' lists one at a time, lowest key
  // first, the pixels of that list together.
  uint key = kEmpty;
#ifdef MYRIAD_CLUSTER_DIRECT  // no tile narrowing: the subgroup walks the cluster's list
  if (surface) key = kSlices + clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice));
#else
  if (surface) {
    key = k < kSlices && segmentLength[k] != kWholeList
              ? k
              : kSlices + clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice));
  }
#endif
  bool pending = key != kEmpty;
  vec3 position = surface ? s.position : vec3(0.0);
#ifdef MYRIAD_CLUSTER_PREPARED
  BrdfSurface brdf;
  if (surface) brdf = brdfSurfaceOf(s);
#endif
#ifdef MYRIAD_CLUSTER_QUEUE
  uint queued = 0u;
#endif
  while (subgroupAny(pending)) {
    uint current = subgroupMin(pending ? key : kEmpty);
    bool mine = pending && key == current;
    pending = pending && !mine;
    vec3 lo = subgroupMin(mine ? position : vec3(3.0e38));
    vec3 hi = subgroupMax(mine ? position : vec3(-3.0e38));
    widenBox(lo, hi);
    bool inShared = current < kSlices;
    uint start, count;
    if (inShared) {
      start = segmentStart[current];
      count = segmentLength[current];
    } else {
      uvec2 range = clusterRanges[current - kSlices];
      start = range.x;
      count = range.y;
    }
    for (uint base = 0u; base < count; base += gl_SubgroupSize) {
      uint i = base + gl_SubgroupInvocationID;
      bool candidate = false;
      if (i < count) {
        uint index = inShared ? tileLights[start + i] : clusterLights[start + i];
        vec4 light = lights[index].positionRadius;
        candidate = sphereOverlapsBox(light.xyz, light.w, lo, hi);
      }
      uvec4 ballot = subgroupBallot(candidate);
      for (uint w = 0u; w * 32u < gl_SubgroupSize; ++w) {
        uint bits = ballot[w];
        while (bits != 0u) {
          uint at = start + base + w * 32u + uint(findLSB(bits));
          bits &= bits - 1u;
          uint index = inShared ? tileLights[at] : clusterLights[at];
          if (mine && lightReaches(s, index)) {
#ifdef MYRIAD_CLUSTER_QUEUE
            queue[queued * kThreads + thread] = index;
            ++queued;
#else
            color += MYRIAD_SHADE(index);
#endif
            ++reached;
          }
#ifdef MYRIAD_CLUSTER_QUEUE
          if (subgroupAny(queued == kQueue)) flushQueue(s, brdf, thread, color, queued);
#endif
        }
      }
    }
  }
#ifdef MYRIAD_CLUSTER_QUEUE
  flushQueue(s, brdf, thread, color, queued);
#endif
#else
  if (surface) {
    uint count = k < kSlices ? segmentLength[k] : kWholeList;
    if (count != kWholeList) {
      uint start = segmentStart[k];
      for (uint i = 0u; i < count; ++i) {
        uint index = tileLights[start + i];
        if (lightReaches(s, index)) {
          color += shadeLight(s, index);
          ++reached;
        }
      }
    } else {
      uvec2 range = clusterRanges[clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice))];
      for (uint i = 0u; i < range.y; ++i) {
        uint index = clusterLights[range.x + i];
        if (lightReaches(s, index)) {
          color += shadeLight(s, index);
          ++reached;
        }
      }
    }
  }
#endif
  if (!inside) return;
  if (surface) {
    color = withLocalShadows(s, color);
  } else {
    color = backgroundRadiance(pixel);
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
