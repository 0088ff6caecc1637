#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// The resolve pass of the G-buffer rasterised in compute: one thread per pixel. It reads the
// pixel's key, intersects the pixel-centre ray with that triangle for perspective-correct
// barycentrics, interpolates what gbuffer.vert passes on, evaluates the material with the raster
// path's own code (material_core.glsl) and stores the same G-buffer texels; depth goes to a
// buffer the frame copies into the depth target. Pixels no triangle covered get the raster
// path's clear values.
#include "visibility.glsl"
#include "shading.glsl"
#include "material_core.glsl"
#include "cluster_grid.glsl"

layout(local_size_x = MYRIAD_PIXEL_GROUP, local_size_y = MYRIAD_PIXEL_GROUP) in;

layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_DEPTH) writeonly buffer DepthBlock {
  float visibleDepth[];
};
layout(set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_NORMAL, rg16_snorm) uniform writeonly image2D normalTarget;
layout(set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_BASE_COLOR, rgba8) uniform writeonly image2D baseColorTarget;
layout(set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_MATERIAL, rgba8) uniform writeonly image2D materialTarget;
layout(set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_UV, rg16f) uniform writeonly image2D uvTarget;
layout(set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_EMISSIVE, rgba16f) uniform writeonly image2D emissiveTarget;
// A bit per cluster (FrameTargets::clusterMarks), all clear before this pass, then the clusters'
// point bounds (cluster_bounds.glsl), all empty.
layout(std430, set = MYRIAD_SET_VISIBILITY, binding = MYRIAD_BINDING_VISIBILITY_CLUSTER_MARKS) buffer ClusterMarkBlock {
  uint clusterMarks[];
};
#include "cluster_bounds.glsl"

// Adds the pixel's surface point to its cluster's bounds: the subgroup's points reduced per
// cluster first (two clusters; a third and later add their points one by one), so that most
// subgroups (8x4 pixels, mostly one cluster) take one lane's six atomics. The reductions are of
// the bounds' words (unsigned maxima, one instruction each where the device reduces integers in
// hardware, as NVIDIA's since sm_80), not of floats: on the H200 reducing floats was no faster
// (resolve 0.179 against 0.177 ms at 1080p), nor was gathering after the G-buffer's stores
// (0.177; issue 16, stop 18). Called by every invocation of the subgroup that marks.
void addPointBounds(uint cluster, vec3 p) {
  uint first = subgroupBroadcastFirst(cluster);
  bool mine = cluster == first;
  uvec3 hiWords = boundsKeys(p);
  uvec3 loWords = ~hiWords;
  uvec3 lo = subgroupMax(mine ? loWords : uvec3(0u));
  uvec3 hi = subgroupMax(mine ? hiWords : uvec3(0u));
  if (subgroupElect()) addClusterWords(first, lo, hi);
  if (subgroupMin(mine ? 1u : 0u) == 1u) return;
  uint second = subgroupMin(mine ? 0xFFFFFFFFu : cluster);
  bool mine2 = cluster == second;
  lo = subgroupMax(mine2 ? loWords : uvec3(0u));
  hi = subgroupMax(mine2 ? hiWords : uvec3(0u));
  if (subgroupElect()) addClusterWords(second, lo, hi);
  if (!mine && !mine2) addClusterWords(cluster, loWords, hiWords);
}

void storeTexels(ivec2 pixel, GBufferTexels t, vec2 uv) {
  uint written = frame.written.x;
  imageStore(normalTarget, pixel, vec4(t.normal, 0.0, 0.0));
  // The raster path's target is sRGB, encoded on store; this view is UNORM, so encode here.
  imageStore(baseColorTarget, pixel, vec4(srgbEncode3(t.baseColor.rgb), t.baseColor.a));
  imageStore(materialTarget, pixel, t.material);
  if ((written & MYRIAD_GBUFFER_UV) != 0u) imageStore(uvTarget, pixel, vec4(uv, 0.0, 0.0));
  if ((written & MYRIAD_GBUFFER_EMISSIVE) != 0u) imageStore(emissiveTarget, pixel, t.emissive);
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(frame.viewport.xy);
  if (any(greaterThanEqual(pixel, size))) return;
  uint index = uint(pixel.y) * uint(size.x) + uint(pixel.x);
  uint64_t key = visibilityKeys[index];
  uint id = uint(key & 0xFFFFFFFFul);
  if (id == MYRIAD_VISIBILITY_NONE) {
    visibleDepth[index] = 1.0;
    uint written = frame.written.x;
    imageStore(normalTarget, pixel, vec4(0.0));
    imageStore(baseColorTarget, pixel, vec4(0.0));
    imageStore(materialTarget, pixel, vec4(0.0));
    if ((written & MYRIAD_GBUFFER_UV) != 0u) imageStore(uvTarget, pixel, vec4(0.0));
    if ((written & MYRIAD_GBUFFER_EMISSIVE) != 0u) imageStore(emissiveTarget, pixel, vec4(0.0));
    return;
  }
  // The depth the visibility pass compared: the value the raster path's depth test kept.
  float depth = uintBitsToFloat(uint(key >> 32));
  visibleDepth[index] = depth;
  uint clusterWork = frame.written.z;
  if ((clusterWork & MYRIAD_RESOLVE_MARKS) != 0u && depth < 1.0) {
    // The clustered technique's step 1 (cluster_mark.comp's pixel pass on the raster path): this
    // pixel's cluster holds geometry. The same depth bits the depth target gets, the same
    // arithmetic (cluster_grid.glsl) as the shading pass. Most pixels find the bit set and only
    // read.
    uint cluster = clusterOfPixel(pixel, depth);
    markClusterBit(cluster);
    if ((clusterWork & MYRIAD_RESOLVE_BOUNDS) != 0u) {
      addPointBounds(cluster, worldFromDepth(pixel, depth));  // the point the shading finds
    }
  }

  TriangleRef ref = triangleRef(id);
  GpuInstance instance = instances[ref.instance];
  vec3 p[3];
  for (uint i = 0u; i < 3u; ++i) {
    p[i] = (instance.model * vec4(vertexPosition(ref.vertices[i]), 1.0)).xyz;
  }
  // The ray through the pixel centre, from the near plane to the far plane.
  vec2 ndc = (vec2(pixel) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 nearPoint = frame.inverseViewProjection * vec4(ndc, 0.0, 1.0);
  vec4 farPoint = frame.inverseViewProjection * vec4(ndc, 1.0, 1.0);
  vec3 origin = nearPoint.xyz / nearPoint.w;
  vec3 direction = farPoint.xyz / farPoint.w - origin;
  // Moller-Trumbore: where the ray meets the triangle's plane, in barycentrics. They are the
  // perspective-correct weights the raster path interpolates with; clamped, as a covered pixel
  // centre lies inside the triangle up to rounding.
  vec3 e1 = p[1] - p[0];
  vec3 e2 = p[2] - p[0];
  vec3 pv = cross(direction, e2);
  float det = dot(e1, pv);
  vec3 tv = origin - p[0];
  vec3 qv = cross(tv, e1);
  float u = det != 0.0 ? dot(tv, pv) / det : 0.0;
  float v = det != 0.0 ? dot(direction, qv) / det : 0.0;
  vec3 b = clamp(vec3(1.0 - u - v, u, v), 0.0, 1.0);
  b /= max(b.x + b.y + b.z, 1e-20);

  // a0 + b1 (a1 - a0) + b2 (a2 - a0): an attribute equal at the three vertices comes out exactly
  // (a weighted sum could land an ulp off and round the other way in an 8-bit target).
  mat3 normalMatrix = mat3(instance.normalMatrix);
  uint v0 = ref.vertices[0], v1 = ref.vertices[1], v2 = ref.vertices[2];
  vec3 n0 = normalMatrix * vertexNormal(v0);
  vec3 normal = n0 + b.y * (normalMatrix * vertexNormal(v1) - n0) +
                b.z * (normalMatrix * vertexNormal(v2) - n0);
  vec2 uv0 = vertexUv(v0);
  vec2 uv = uv0 + b.y * (vertexUv(v1) - uv0) + b.z * (vertexUv(v2) - uv0);
  vec4 c0 = vertexColor(v0);
  vec4 color = c0 + b.y * (vertexColor(v1) - c0) + b.z * (vertexColor(v2) - c0);
  // gl_FrontFacing: counter-clockwise on screen, i.e. the winding's normal facing the camera.
  vec3 faceNormal = cross(e1, e2);
  float side = dot(faceNormal, frame.cameraPosition.xyz - p[0]) > 0.0 ? 1.0 : -1.0;
  // The raster path's fallback normal is cross(dFdx(position), dFdy(position)), which points
  // away from the viewer on either side (y runs down the screen).
  GpuMaterial material = materials[instance.material.x];
  MaterialSample m = withUnlit(material, untexturedMaterial(material, color, normal,
                                                            -side * faceNormal, side));
  storeTexels(pixel, gbufferTexels(m), uv);
}
