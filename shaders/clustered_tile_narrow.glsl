// Clustered step 5's first half, shared by light_clustered.comp (a walk per pixel) and
// light_clustered_subgroup.comp (a walk per subgroup): a MYRIAD_CLUSTER_SHADE_TILE-square
// workgroup narrows the lists of the clusters its pixels fall in to the lights whose sphere
// overlaps the box around its own pixels: its rectangle between the nearest and farthest surface
// depth of its pixels in that slice (the geometry's actual depth range, not the slice's). The
// narrowed lists live in shared memory, one segment per slice of the tile's span. The test is
// conservative (a margin covers rounding); a slice whose narrowed list overflows the shared
// capacity gets the length kWholeList, and its pixels walk their cluster's whole list.
// Needs frame.glsl and compute_targets.glsl included first, and from the includer:
//   kNarrowWorld   (bool) the box is the world-space bounds of the slice's surface points
//                  (flat on a floor: the lights' spheres must reach down to it), else the view box
//   kNarrowLoads   (uint, 1-4) list entries an invocation loads before testing them
//   MYRIAD_NARROW_SUBGROUP (macro) the includer has the subgroup vote and arithmetic
//                  extensions (kNarrowWorld's bounds are then reduced per subgroup first), and
//                  then kNarrowKeys (bool): reduced as orderedBits words, not floats

const uint kThreads = MYRIAD_CLUSTER_SHADE_TILE * MYRIAD_CLUSTER_SHADE_TILE;
const uint kSlices = MYRIAD_CLUSTER_TILE_SLICES;
const uint kCapacity = MYRIAD_CLUSTER_TILE_LIGHTS;
const uint kWholeList = 0xFFFFFFFFu;  // a segment's length when its pixels walk the cluster's list

shared uint tileLights[kCapacity];
shared uint firstSlice;
shared uint lastSlice;
shared uint depthLo[kSlices];  // view depth bits (positive floats order as their bits do)
shared uint depthHi[kSlices];
shared uint worldLo[3 * kSlices];  // kNarrowWorld: the points' bounds, orderedBits
shared uint worldHi[3 * kSlices];
shared uint used;
shared uint nextStart;  // where the next slice's segment starts (thread 0 keeps it)
shared uint segmentStart[kSlices];
shared uint segmentLength[kSlices];

const uint kNoSlice = 0xFFFFFFFFu;  // firstSlice of a tile with no surface; no pixel's key

// A float's bits mapped so that unsigned order is the floats' order (negatives reversed).
uint orderedBits(float f) {
  uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float fromOrderedBits(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7FFFFFFFu : ~u);
}

// Whether the light (world centre light.xyz, radius light.w) may reach a point in the box.
bool lightMayReachTile(vec4 light, vec3 lo, vec3 hi) {
  vec3 c = kNarrowWorld ? light.xyz : (frame.view * vec4(light.xyz, 1.0)).xyz;
  return sphereOverlapsBox(c, light.w, lo, hi);
}

// Appends the light to the tile's list when it may reach the box (lightMayReachTile).
void keepIfMayReach(uint index, vec4 light, vec3 lo, vec3 hi) {
  if (lightMayReachTile(light, lo, hi)) {
    uint slot = atomicAdd(used, 1u);
    if (slot < kCapacity) tileLights[slot] = index;
  }
}

// Called by every invocation of the workgroup (it holds barriers), with the invocation's index,
// whether its pixel holds a surface, and that surface's slice, view depth and world position.
// Returns the pixel's segment, an index into segmentStart / segmentLength when below kSlices.
uint narrowTileLists(uint thread, bool surface, uint slice, float viewDepth, vec3 position) {
  if (thread == 0u) {
    firstSlice = kNoSlice;
    lastSlice = 0u;
    used = 0u;
    nextStart = 0u;
  }
  if (thread < kSlices) {
    depthLo[thread] = 0xFFFFFFFFu;
    depthHi[thread] = 0u;
  }
  if (kNarrowWorld && thread < 3u * kSlices) {
    worldLo[thread] = 0xFFFFFFFFu;
    worldHi[thread] = 0u;
  }
  barrier();
  if (surface) {
    atomicMin(firstSlice, slice);
    atomicMax(lastSlice, slice);
  }
  barrier();
  uint k = slice - firstSlice;  // this pixel's segment
  bool counted = surface && k < kSlices;
  if (counted) {
    atomicMin(depthLo[k], floatBitsToUint(viewDepth));
    atomicMax(depthHi[k], floatBitsToUint(viewDepth));
  }
  if (kNarrowWorld) {
#ifdef MYRIAD_NARROW_SUBGROUP
    // Most subgroups' pixels share a slice: their bounds reduced first, one lane's atomics.
    uint sameK = subgroupAllEqual(counted ? k : kNoSlice) ? 1u : 0u;
    if (sameK == 1u && kNarrowKeys) {
      // The words reduced (kNarrowKeys): the same bounds.
      uvec3 keys = uvec3(orderedBits(position.x), orderedBits(position.y), orderedBits(position.z));
      uvec3 lo = subgroupMin(keys);
      uvec3 hi = subgroupMax(keys);
      if (counted && subgroupElect()) {
        for (uint a = 0u; a < 3u; ++a) {
          atomicMin(worldLo[3u * k + a], lo[a]);
          atomicMax(worldHi[3u * k + a], hi[a]);
        }
      }
    } else if (sameK == 1u) {
      vec3 lo = subgroupMin(position);
      vec3 hi = subgroupMax(position);
      if (counted && subgroupElect()) {
        for (uint a = 0u; a < 3u; ++a) {
          atomicMin(worldLo[3u * k + a], orderedBits(lo[a]));
          atomicMax(worldHi[3u * k + a], orderedBits(hi[a]));
        }
      }
    } else if (counted) {
      for (uint a = 0u; a < 3u; ++a) {
        atomicMin(worldLo[3u * k + a], orderedBits(position[a]));
        atomicMax(worldHi[3u * k + a], orderedBits(position[a]));
      }
    }
#else
    if (counted) {
      for (uint a = 0u; a < 3u; ++a) {
        atomicMin(worldLo[3u * k + a], orderedBits(position[a]));
        atomicMax(worldHi[3u * k + a], orderedBits(position[a]));
      }
    }
#endif
  }
  barrier();

  // Narrow each occupied slice's list in turn, over the tile's span of slices only. The loop's
  // bound and conditions read shared memory after a barrier, so every invocation takes the same
  // path through the two barriers inside (on lavapipe each barrier switches all the workgroup's
  // invocations: walking all kSlices with three barriers each was half the pass's time).
  uvec2 tile = gl_WorkGroupID.xy * MYRIAD_CLUSTER_SHADE_TILE / clusterTileSize();
  vec2 rectLo = vec2(gl_WorkGroupID.xy * MYRIAD_CLUSTER_SHADE_TILE);
  vec2 rectHi = min(rectLo + vec2(MYRIAD_CLUSTER_SHADE_TILE), frame.viewport.xy);
  uint span = firstSlice == kNoSlice ? 0u : min(lastSlice - firstSlice + 1u, kSlices);
  for (uint j = 0u; j < span; ++j) {
    if (depthHi[j] == 0u) continue;
    uvec2 range = clusterRanges[clusterIndex(uvec3(tile, firstSlice + j))];
    vec3 lo, hi;
    if (kNarrowWorld) {
      // The points' own bounds: a light reaching one of them (|light - point|^2 < radius^2,
      // rounded) overlaps them widened by 1e-5 of the coordinates' size, far more than rounding.
      lo = vec3(fromOrderedBits(worldLo[3u * j]), fromOrderedBits(worldLo[3u * j + 1u]),
                fromOrderedBits(worldLo[3u * j + 2u]));
      hi = vec3(fromOrderedBits(worldHi[3u * j]), fromOrderedBits(worldHi[3u * j + 1u]),
                fromOrderedBits(worldHi[3u * j + 2u]));
      vec3 margin = 1e-5 * (max(abs(lo), abs(hi)) + vec3(1.0));
      lo -= margin;
      hi += margin;
    } else {
      float z0 = uintBitsToFloat(depthLo[j]);
      float z1 = uintBitsToFloat(depthHi[j]);
      viewBoxOfRect(rectLo, rectHi, z0, z1, lo, hi);
      // Pixel positions come from the depth through the inverse view-projection, the box from
      // the projection's scale: widen it by far more than their rounding apart.
      vec3 margin = vec3(1e-3 * z1 + 1e-4);
      lo -= margin;
      hi += margin;
    }
    // kNarrowLoads entries an invocation a step, all loaded before any is tested: the loads of
    // a list entry and then its light are what the narrowing waits on.
    for (uint i = thread; i < range.y; i += kThreads * kNarrowLoads) {
      uint i1 = i + kThreads;
      uint i2 = i + 2u * kThreads;
      uint i3 = i + 3u * kThreads;
      bool has1 = kNarrowLoads > 1u && i1 < range.y;
      bool has2 = kNarrowLoads > 2u && i2 < range.y;
      bool has3 = kNarrowLoads > 3u && i3 < range.y;
      uint index0 = clusterLights[range.x + i];
      uint index1 = has1 ? clusterLights[range.x + i1] : 0u;
      uint index2 = has2 ? clusterLights[range.x + i2] : 0u;
      uint index3 = has3 ? clusterLights[range.x + i3] : 0u;
      vec4 light0 = lights[index0].positionRadius;
      vec4 light1 = has1 ? lights[index1].positionRadius : vec4(0.0);
      vec4 light2 = has2 ? lights[index2].positionRadius : vec4(0.0);
      vec4 light3 = has3 ? lights[index3].positionRadius : vec4(0.0);
      keepIfMayReach(index0, light0, lo, hi);
      if (has1) keepIfMayReach(index1, light1, lo, hi);
      if (has2) keepIfMayReach(index2, light2, lo, hi);
      if (has3) keepIfMayReach(index3, light3, lo, hi);
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
  return k;
}
