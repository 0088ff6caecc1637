#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
// Clustered step 5 on devices with subgroup vote, arithmetic, ballot and shuffle in compute
// (light_clustered.comp is the per-pixel pass for the others and for CPU devices): each pixel
// shades sun + ambient + the lights of its cluster's list.
//
// The tile's narrowing is light_clustered.comp's (clustered_tile_narrow.glsl): each 16x16-pixel
// workgroup narrows the lists of the clusters its pixels fall in, into shared memory, one segment
// per slice; by default (kNarrowWorld) to the lights overlapping the world-space bounds of its
// surface points in that slice, else the view box of its rectangle between its pixels' nearest
// and farthest depth there. Its invocations follow Morton order, so a subgroup of 32 is an
// 8x4-pixel block (8: 4x2).
//
// Then each subgroup walks its pixels' segments one at a time, the pixels of that segment
// together, in one of two ways (kVariant: MYRIAD_SHADE_* bits; bench/history/
// performance-2026-11-to-12.md, "stop 16"):
// - per pixel, a light a step, every lane the same light: short segments (kShortFrom);
// - the mask walk: chunks of a subgroup's size, a light per lane, tested against the box of the
//   subgroup's surface points; lights holding the whole box reach every pixel and are stepped
//   through together; for the rest every pixel keeps a mask of those near it and loops over its
//   own mask, as long as the subgroup's largest mask rather than the union of its pixels' lights
//   (1.1-4x a pixel's count where the subgroup spans much of the floor, far from the camera).
// (kVariant 0, the walk before stop 16: per pixel up to kBallotFrom lights, beyond by ballot over
// the union.) The BRDF's terms that depend on the pixel alone (brdfSurfaceOf) are worked out once
// per pixel.
//
// Every test is conservative (boxes widened by far more than rounding) and each pixel still
// decides every light exactly (lightReaches, lightReachesFrom), so the image and the light counts
// are those of the whole list. A tile whose narrowed lists overflow the shared capacity, or whose
// pixels span more than MYRIAD_CLUSTER_TILE_SLICES slices, walks the whole list there.
#include "frame.glsl"
#include "compute_targets.glsl"

// How this pipeline narrows and walks (MYRIAD_SHADE_* bits of shared_types.h): the technique
// sets MYRIAD_SHADE_DEFAULT, or --tune shade-variant's number (a benchmark experiment).
layout(constant_id = MYRIAD_SPEC_SHADE_VARIANT) const uint kVariant = MYRIAD_SHADE_DEFAULT;
const bool kMaskWalk = (kVariant & MYRIAD_SHADE_MASK_WALK) != 0u;
const bool kBoxAlways = (kVariant & MYRIAD_SHADE_BOX_ALWAYS) != 0u;
const bool kNarrowWorld = (kVariant & MYRIAD_SHADE_NARROW_WORLD) != 0u;
const bool kHybrid = (kVariant & MYRIAD_SHADE_HYBRID) != 0u;
// The subgroups' bounds of their points (the narrowing's and each segment's box) reduced as
// orderedBits words, unsigned (one instruction each where the device reduces integers in
// hardware, as NVIDIA's since sm_80), not as floats (a shuffle a step). The same boxes but for
// the sign of a zero, which no overlap test can tell apart.
const bool kNarrowKeys = (kVariant & MYRIAD_SHADE_KEYS) != 0u;
// The mask walk leaves segments of at most this many lights to the walk per pixel.
const uint kShortFrom = (kVariant & MYRIAD_SHADE_SHORT_64) != 0u ? 64u : 0u;
const bool kNarrowOnly = (kVariant & MYRIAD_SHADE_DIAG_NARROW_ONLY) != 0u;
const bool kNoBrdf = (kVariant & MYRIAD_SHADE_DIAG_NO_BRDF) != 0u;
// Measurements of the mask walk's parts: each skips one and counts what it would have tested.
const bool kNoShort = (kVariant & MYRIAD_SHADE_DIAG_NO_SHORT) != 0u;
const bool kNoTogether = (kVariant & MYRIAD_SHADE_DIAG_NO_TOGETHER) != 0u;
const bool kNoApart = (kVariant & MYRIAD_SHADE_DIAG_NO_APART) != 0u;
const bool kNoNear = (kVariant & MYRIAD_SHADE_DIAG_NO_NEAR) != 0u;
// The narrowing's list entries in flight per invocation (clustered_tile_narrow.glsl): 4 against
// 1 took 0.013 ms off the shade pass at 1080p with a million lights on the H200.
const uint kNarrowLoads = 4u;
#define MYRIAD_NARROW_SUBGROUP
#include "clustered_tile_narrow.glsl"  // the narrowing, shared with light_clustered.comp

layout(local_size_x = MYRIAD_CLUSTER_SHADE_TILE * MYRIAD_CLUSTER_SHADE_TILE) in;

// kVariant without kMaskWalk: segments longer than this the subgroup walks by ballot over the
// union (on the H200 ballot from 0 / 128 / 256 / never: bench/history/
// performance-2026-11-to-12.md, "clustered shading walked per subgroup").
const uint kBallotFrom = 256u;

// lightReaches and shadeLightAt for light `index` whose position and radius the caller holds
// (positionRadius, the light's own): the same decision and sum, the rest of the light loaded.
bool lightReachesFrom(Surface s, uint index, vec4 positionRadius) {
  vec3 toLight = positionRadius.xyz - s.position;
  if (dot(toLight, toLight) >= positionRadius.w * positionRadius.w) {
    return false;
  }
  if (!MYRIAD_MAY_SPOT) return true;
  return localLightReaches(s.position, positionRadius.xyz, positionRadius.w,
                           spotDirectionOf(lights[index]), lights[index].cone.z);
}
vec3 shadeLightFrom(BrdfSurface b, Surface s, uint index, vec4 positionRadius,
                    vec4 radianceFalloff) {
  vec4 cone = MYRIAD_MAY_SPOT ? lights[index].cone : vec4(0.0, 0.0, -2.0, -1.0);
  return shadeLocalLightAt(b, s.position, positionRadius.xyz, positionRadius.w, radianceFalloff.rgb,
                           radianceFalloff.w, octahedralDecode(cone.xy), cone.z, cone.w);
}

// Word w of a ballot. Indexed by a loop's counter (ballot[w]), NVIDIA's compiler kept the ballots
// in local memory (64 bytes a thread); selects keep them in registers (H200: the shade pass
// 0.012 ms faster at 1080p with a million lights).
uint ballotWord(uvec4 ballot, uint w) {
  return w == 0u ? ballot.x : w == 1u ? ballot.y : w == 2u ? ballot.z : ballot.w;
}

void main() {
  // Morton order inside the tile: bit 2i of the invocation index is bit i of x, bit 2i+1 of y.
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
  ivec2 pixel = ivec2(gl_WorkGroupID.xy * MYRIAD_CLUSTER_SHADE_TILE + inTile);
  bool inside = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  float depth = inside ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
  Surface s;
  bool surface = inside && loadSurfaceWithDepth(pixel, depth, s);
  float viewDepth = viewDepthFromDepth(depth);
  uint slice = sliceOfViewDepth(viewDepth);

  uint k = narrowTileLists(thread, surface, slice, viewDepth, surface ? s.position : vec3(0.0));

  vec3 color = vec3(0.0);
  uint reached = 0u;
  BrdfSurface brdf;
  if (surface) {
    color = sunAndAmbient(s);
    brdf = brdfSurfaceOf(s);
  }
  // The list this pixel walks: its slice's segment (key < kSlices) or its cluster's whole list
  // (kSlices + cluster index).
  uint key = kNoSlice;
  if (surface) {
    key = k < kSlices && segmentLength[k] != kWholeList
              ? k
              : kSlices + clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice));
  }
  bool pending = key != kNoSlice;
  vec3 position = surface ? s.position : vec3(0.0);
  if (kNarrowOnly) {  // a measurement: the narrowing alone (its lengths kept live)
    pending = false;
    if (surface && k < kSlices) reached = segmentLength[k];
  }
  while (subgroupAny(pending)) {
    uint current = subgroupMin(pending ? key : kNoSlice);
    bool mine = pending && key == current;
    pending = pending && !mine;
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
    if (kMaskWalk ? count <= kShortFrom : count <= kBallotFrom) {
      if (kNoShort) {
        if (mine) reached += count;
        continue;
      }
      if (mine) {
        for (uint i = 0u; i < count; ++i) {
          uint index = inShared ? tileLights[start + i] : clusterLights[start + i];
          if (lightReaches(s, index)) {
            if (!kNoBrdf) color += shadeLightAt(brdf, s, index);
            ++reached;
          }
        }
      }
      continue;
    }
    // The box of the subgroup's points on this list, widened so that a light reaching one of
    // them (|light - point|^2 < radius^2, rounded) always overlaps it (rounded): 1e-5 of the
    // coordinates' size is far more than either test's rounding.
    vec3 lo, hi;
    if (kNarrowKeys) {
      uvec3 keys = uvec3(orderedBits(position.x), orderedBits(position.y), orderedBits(position.z));
      uvec3 loKeys = subgroupMin(mine ? keys : uvec3(0xFFFFFFFFu));
      uvec3 hiKeys = subgroupMax(mine ? keys : uvec3(0u));
      lo = vec3(fromOrderedBits(loKeys.x), fromOrderedBits(loKeys.y), fromOrderedBits(loKeys.z));
      hi = vec3(fromOrderedBits(hiKeys.x), fromOrderedBits(hiKeys.y), fromOrderedBits(hiKeys.z));
    } else {
      lo = subgroupMin(mine ? position : vec3(3.0e38));
      hi = subgroupMax(mine ? position : vec3(-3.0e38));
    }
    vec3 margin = 1e-5 * (max(abs(lo), abs(hi)) + vec3(1.0));
    lo -= margin;
    hi += margin;
    if (kMaskWalk) {
      // Chunks of a subgroup's size: each lane loads one light and, on a long segment (or
      // always, kBoxAlways), tests it against the subgroup's box. Then every pixel tests each
      // candidate's reach and keeps a mask of those reaching it, and shades its own mask's
      // lights: a loop as long as the subgroup's largest mask, not as its union of lights (which
      // is 1.1x-4x a pixel's count where a subgroup spans much of the floor). kHybrid: a light
      // whose sphere holds the whole box reaches every pixel of the subgroup, which steps
      // through those lights together instead (as the walk for short segments does).
      bool box = kBoxAlways || count > kBallotFrom;
      for (uint base = 0u; base < count; base += gl_SubgroupSize) {
        uint i = base + gl_SubgroupInvocationID;
        uint index = 0u;
        vec4 light = vec4(0.0);
        bool candidate = false;
        bool covers = false;
        if (i < count) {
          index = inShared ? tileLights[start + i] : clusterLights[start + i];
          light = lights[index].positionRadius;
          candidate = !box || sphereOverlapsBox(light.xyz, light.w, lo, hi);
          if (kHybrid && candidate) {
            vec3 far = max(abs(light.xyz - lo), abs(light.xyz - hi));  // the box's farthest corner
            covers = dot(far, far) < light.w * light.w;
          }
        }
        uvec4 together = subgroupBallot(candidate && covers);
        uvec4 apart = subgroupBallot(candidate && !covers);
        // lightReaches' own first test loosened by far more than rounding (it decides), its
        // squared reach worked out once by the lane holding the light and passed round with the
        // position (H200: 0.006 ms off the pass at 1080p with a million lights, 0.014 at 4K).
        vec4 loose = vec4(light.xyz, light.w * light.w * 1.0001 + 1e-12);
        for (uint w = 0u; w * 32u < gl_SubgroupSize; ++w) {
          uint bits = ballotWord(together, w);
          if (kNoTogether) {
            if (mine) reached += bitCount(bits);
            bits = 0u;
          }
          while (bits != 0u) {  // kHybrid: lights reaching the whole subgroup, every lane at once
            uint lane = w * 32u + uint(findLSB(bits));
            bits &= bits - 1u;
            uint candidateIndex = subgroupShuffle(index, lane);
            vec4 candidateLight = subgroupShuffle(light, lane);
            if (mine && lightReachesFrom(s, candidateIndex, candidateLight)) {
              if (!kNoBrdf) {
                color += shadeLightFrom(brdf, s, candidateIndex, candidateLight,
                                        lights[candidateIndex].radianceFalloff);
              }
              ++reached;
            }
          }
          bits = ballotWord(apart, w);
          uint near = 0u;
          if (kNoApart) {
            if (mine) reached += bitCount(bits);
            bits = 0u;
          }
          while (bits != 0u) {
            uint bit = uint(findLSB(bits));
            bits &= bits - 1u;
            vec4 candidateLoose = subgroupShuffle(loose, w * 32u + bit);
            vec3 toLight = candidateLoose.xyz - position;
            if (dot(toLight, toLight) < candidateLoose.w) near |= 1u << bit;
          }
          if (!mine) near = 0u;
          if (kNoNear) {
            reached += bitCount(near);
            near = 0u;
          }
          while (near != 0u) {
            uint bit = uint(findLSB(near));
            near &= near - 1u;
            uint j = start + base + w * 32u + bit;
            uint candidateIndex = inShared ? tileLights[j] : clusterLights[j];
            vec4 candidateLight = lights[candidateIndex].positionRadius;
            if (lightReachesFrom(s, candidateIndex, candidateLight)) {
              if (!kNoBrdf) {
                color += shadeLightFrom(brdf, s, candidateIndex, candidateLight,
                                        lights[candidateIndex].radianceFalloff);
              }
              ++reached;
            }
          }
        }
      }
      continue;
    }
    for (uint base = 0u; base < count; base += gl_SubgroupSize) {
      uint i = base + gl_SubgroupInvocationID;
      uint index = 0u;
      vec4 light = vec4(0.0);
      bool candidate = false;
      if (i < count) {
        index = inShared ? tileLights[start + i] : clusterLights[start + i];
        light = lights[index].positionRadius;
        candidate = sphereOverlapsBox(light.xyz, light.w, lo, hi);
      }
      uvec4 ballot = subgroupBallot(candidate);
      for (uint w = 0u; w * 32u < gl_SubgroupSize; ++w) {
        uint bits = ballotWord(ballot, w);
        while (bits != 0u) {
          uint lane = w * 32u + uint(findLSB(bits));
          bits &= bits - 1u;
          uint candidateIndex = subgroupShuffle(index, lane);
          vec4 candidateLight = subgroupShuffle(light, lane);
          // lightReaches' own first test, on the light the lane already holds and loosened by
          // far more than rounding: a light failing it fails lightReaches, which decides.
          vec3 toLight = candidateLight.xyz - s.position;
          float r2 = candidateLight.w * candidateLight.w;
          if (mine && dot(toLight, toLight) < r2 * 1.0001 + 1e-12 &&
              lightReaches(s, candidateIndex)) {
            if (!kNoBrdf) color += shadeLightAt(brdf, s, candidateIndex);
            ++reached;
          }
        }
      }
    }
  }
  if (!inside) return;
  if (surface) {
    color = withLocalShadows(s, color);
  } else {
    color = backgroundRadiance(pixel);
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
