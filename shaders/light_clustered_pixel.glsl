// Clustered step 5 (light_clustered.comp, light_clustered_whole.comp): each pixel shades sun + ambient + the lights of its cluster's list. This is
// the pass on CPU devices and where compute shaders lack subgroup operations; GPUs with them run
// light_clustered_subgroup.comp, the same narrowing (there against the world bounds of the
// tile's surface points) with a walk per subgroup.
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
//
// MYRIAD_SHADE_WHOLE_LISTS (light_clustered_whole.comp): no narrowing, every pixel walks its
// cluster's whole list: the same lights reach each pixel, so the same image and light counts.
// On a CPU device with short lists (the built-in scene's longest is 22) the narrowing costs more
// than it saves: its workgroup barriers and shared memory are what llvmpipe runs slowest.
#include "frame.glsl"
#include "compute_targets.glsl"
#ifndef MYRIAD_SHADE_WHOLE_LISTS
const bool kNarrowWorld = false;   // the view box of the tile's rectangle and depth range
const uint kNarrowLoads = 1u;  // entries in flight per invocation: 4 was measured on the H200 only
#include "clustered_tile_narrow.glsl"  // the narrowing, shared with the subgroup pass
#endif

layout(local_size_x = MYRIAD_CLUSTER_SHADE_TILE, local_size_y = MYRIAD_CLUSTER_SHADE_TILE) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint thread = gl_LocalInvocationIndex;
  bool inside = pixel.x < int(frame.viewport.x) && pixel.y < int(frame.viewport.y);
  float depth = inside ? texelFetch(gbufferDepth, pixel, 0).r : 1.0;
  Surface s;
  bool surface = inside && loadSurfaceWithDepth(pixel, depth, s);
  float viewDepth = viewDepthFromDepth(depth);
  uint slice = sliceOfViewDepth(viewDepth);

#ifdef MYRIAD_SHADE_WHOLE_LISTS
  const bool narrowed = false;
#else
  uint k = narrowTileLists(thread, surface, slice, viewDepth, vec3(0.0));
  uint count = k < kSlices ? segmentLength[k] : kWholeList;
  bool narrowed = count != kWholeList;
#endif

  if (!inside) return;
  vec3 color = backgroundRadiance(pixel);
  uint reached = 0u;
  if (surface) {
    color = sunAndAmbient(s);
    if (narrowed) {
#ifndef MYRIAD_SHADE_WHOLE_LISTS
      uint start = segmentStart[k];
      for (uint i = 0u; i < count; ++i) {
        uint index = tileLights[start + i];
        if (lightReaches(s, index)) {
          color += shadeLight(s, index);
          ++reached;
        }
      }
#endif
    } else {
      uvec2 range = clusterRanges[clusterIndex(uvec3(uvec2(pixel) / clusterTileSize(), slice))];
      for (uint i = 0u; i < range.y; ++i) {
        uint index = clusterLights[range.x + i];
#ifdef MYRIAD_SHADE_WHOLE_LISTS
        // CPU devices: the light from its texels (shared_types.h MYRIAD_BINDING_LIGHT_TEXELS),
        // the rest of it only within its radius, as lightReaches.
        if (withinLightRadius(s, lightTexel(index, 0u))) {
          GpuPointLight light = lightFromTexels(index);
          if (lightDataReaches(s, light)) {
            color += shadeLightData(s, light);
            ++reached;
          }
        }
#else
        if (lightReaches(s, index)) {
          color += shadeLight(s, index);
          ++reached;
        }
#endif
      }
    }
    color = withLocalShadows(s, color);
  }
  imageStore(hdrOut, pixel, vec4(color, 1.0));
  imageStore(lightCountOut, pixel, vec4(float(reached)));
}
