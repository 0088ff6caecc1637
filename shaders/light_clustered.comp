#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 5: each pixel shades sun + ambient + the lights of its cluster's list. This is
// the pass on CPU devices and where compute shaders lack subgroup operations; GPUs with them run
// light_clustered_subgroup.comp, the same narrowing with a walk per subgroup.
//
// A 64x64-pixel cluster's list holds every light overlapping the whole frustum segment; with a
// million small lights that is thousands of lights of which a pixel's few dozen reach it. So each
// MYRIAD_CLUSTER_SHADE_TILE-square workgroup first narrows the lists of the clusters its pixels fall in to
// the lights whose sphere overlaps the box around its own pixels: its 16x16-pixel rectangle
// between the nearest and farthest surface depth of its pixels in that slice (the geometry's actual
// depth range, not the slice's). The narrowed lists live in shared memory, one segment per slice,
// and each pixel walks its slice's segment. The test is conservative (a margin covers rounding),
// and each pixel still decides every light exactly (lightReaches), so the image and the light
// counts are those of the whole list. A tile whose narrowed lists overflow the shared capacity, or
// whose pixels span more than MYRIAD_CLUSTER_TILE_SLICES slices, walks the whole list there.
#include "frame.glsl"
#include "compute_targets.glsl"

layout(local_size_x = MYRIAD_CLUSTER_SHADE_TILE, local_size_y = MYRIAD_CLUSTER_SHADE_TILE) in;

const uint kThreads = MYRIAD_CLUSTER_SHADE_TILE * MYRIAD_CLUSTER_SHADE_TILE;
const uint kSlices = MYRIAD_CLUSTER_TILE_SLICES;
const uint kCapacity = MYRIAD_CLUSTER_TILE_LIGHTS;
const uint kWholeList = 0xFFFFFFFFu;  // a segment's length when its pixels walk the cluster's list

shared uint tileLights[kCapacity];
shared uint firstSlice;
shared uint lastSlice;
shared uint depthLo[kSlices];  // view depth bits (positive floats order as their bits do)
shared uint depthHi[kSlices];
shared uint used;
shared uint nextStart;  // where the next slice's segment starts (thread 0 keeps it)
shared uint segmentStart[kSlices];
shared uint segmentLength[kSlices];

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint thread = gl_LocalInvocationIndex;
  bool inside = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  float depth = inside ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
  Surface s;
  bool surface = inside && loadSurfaceWithDepth(pixel, depth, s);
  float viewDepth = viewDepthFromDepth(depth);
  uint slice = sliceOfViewDepth(viewDepth);

  if (thread == 0u) {
    firstSlice = 0xFFFFFFFFu;
    lastSlice = 0u;
    used = 0u;
    nextStart = 0u;
  }
  if (thread < kSlices) {
    depthLo[thread] = 0xFFFFFFFFu;
    depthHi[thread] = 0u;
  }
  barrier();
  if (surface) {
    atomicMin(firstSlice, slice);
    atomicMax(lastSlice, slice);
  }
  barrier();
  uint k = slice - firstSlice;  // this pixel's segment
  if (surface && k < kSlices) {
    atomicMin(depthLo[k], floatBitsToUint(viewDepth));
    atomicMax(depthHi[k], floatBitsToUint(viewDepth));
  }
  barrier();

  // Narrow each occupied slice's list in turn, over the tile's span of slices only. The loop's
  // bound and conditions read shared memory after a barrier, so every invocation takes the same
  // path through the two barriers inside (on lavapipe each barrier switches all the workgroup's
  // invocations: walking all kSlices with three barriers each was half the pass's time).
  uvec2 tile = gl_WorkGroupID.xy * MYRIAD_CLUSTER_SHADE_TILE / clusterTileSize();
  vec2 rectLo = vec2(gl_WorkGroupID.xy * MYRIAD_CLUSTER_SHADE_TILE);
  vec2 rectHi = min(rectLo + vec2(MYRIAD_CLUSTER_SHADE_TILE), frame.viewport.xy);
  uint span = firstSlice == 0xFFFFFFFFu ? 0u : min(lastSlice - firstSlice + 1u, kSlices);
  for (uint j = 0u; j < span; ++j) {
    if (depthHi[j] == 0u) continue;
    uvec2 range = clusterRanges[clusterIndex(uvec3(tile, firstSlice + j))];
    float z0 = uintBitsToFloat(depthLo[j]);
    float z1 = uintBitsToFloat(depthHi[j]);
    vec3 lo, hi;
    viewBoxOfRect(rectLo, rectHi, z0, z1, lo, hi);
    // Pixel positions come from the depth through the inverse view-projection, the box from the
    // projection's scale: widen it by far more than their rounding apart.
    vec3 margin = vec3(1e-3 * z1 + 1e-4);
    lo -= margin;
    hi += margin;
    for (uint i = thread; i < range.y; i += kThreads) {
      uint index = clusterLights[range.x + i];
      vec4 light = lights[index].positionRadius;
      vec3 c = (frame.view * vec4(light.xyz, 1.0)).xyz;
      if (sphereOverlapsBox(c, light.w, lo, hi)) {
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

  if (!inside) return;
  vec3 color = backgroundRadiance(pixel);
  uint reached = 0u;
  if (surface) {
    color = sunAndAmbient(s);
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
    color = withLocalShadows(s, color);
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
