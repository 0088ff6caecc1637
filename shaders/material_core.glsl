// What a material gives a surface point before any texture, and how the G-buffer stores it:
// shared by the raster G-buffer (material.glsl's evaluateMaterial starts here, then applies the
// texture slots; gbuffer.glsl writes gbufferTexels) and the G-buffer resolved in compute
// (visibility_resolve.comp: untextured materials only), so the two paths store the same values.
// Needs GpuMaterial (shared_types.h) and octahedralEncode (shading.glsl).
#ifndef MYRIAD_MATERIAL_CORE_GLSL
#define MYRIAD_MATERIAL_CORE_GLSL

struct MaterialSample {
  vec4 baseColor;  // linear rgb (not clamped), alpha
  vec3 normal;     // the mapped normal, facing the viewer's side
  float metallic;
  float roughness;
  float occlusion;
  vec3 emissive;   // emitted radiance
};

// `color`: the interpolated vertex colour; `normal`: the interpolated normal (world space);
// `faceNormal`: what replaces a zero or NaN normal (the raster path's cross(dFdx(position),
// dFdy(position))); `side`: 1 for a front face, -1 for a back face (double-sided surfaces seen
// from behind get the flipped normal).
MaterialSample untexturedMaterial(GpuMaterial material, vec4 color, vec3 normal, vec3 faceNormal,
                                  float side) {
  MaterialSample m;
  m.baseColor = material.baseColor * color;
  vec3 n = normal;
  // Broken models (zero or NaN normals) still get a usable normal: the triangle's own.
  if (!(dot(n, n) > 1e-12)) {
    n = faceNormal;
  }
  m.normal = normalize(n) * side;
  m.metallic = material.metallicRoughness.x;
  m.roughness = material.metallicRoughness.y;
  m.occlusion = 1.0;
  m.emissive = material.emissive.rgb;
  return m;
}

// The G-buffer's texels of a material sample, as both paths store them (formats:
// render/frame_targets.h; base colour is linear here, the sRGB encoding is the target's).
struct GBufferTexels {
  vec2 normal;     // octahedral
  vec4 baseColor;
  vec4 material;   // metallic, roughness, occlusion, 1
  vec4 emissive;
};

GBufferTexels gbufferTexels(MaterialSample m) {
  GBufferTexels t;
  t.normal = octahedralEncode(m.normal);
  t.baseColor = vec4(clamp(m.baseColor.rgb, 0.0, 1.0), 1.0);
  t.material = vec4(clamp(vec3(m.metallic, m.roughness, m.occlusion), 0.0, 1.0), 1.0);
  t.emissive = vec4(m.emissive, 1.0);
  return t;
}

#endif
