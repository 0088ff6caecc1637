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
  float reflectance;  // 1: the glTF BRDF reflects light; 0: none (unlit, emission only)
  float dielectricF0;  // the dielectric's Fresnel at normal incidence (0.04 at ior 1.5)
  float specular;      // the dielectric's Fresnel at grazing incidence (KHR_materials_specular)
  float clearcoat;           // KHR_materials_clearcoat's factor (0: no coat)
  float clearcoatRoughness;  // its perceptual roughness
  vec3 sheenColor;           // KHR_materials_sheen's colour (0: no sheen)
  float sheenRoughness;      // its roughness
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
  m.reflectance = 1.0;
  m.dielectricF0 = uintBitsToFloat(material.flags.y);
  m.specular = uintBitsToFloat(material.flags.z);
  m.clearcoat = material.layers.x;
  m.clearcoatRoughness = material.layers.y;
  m.sheenColor = material.sheenColor.rgb;
  m.sheenRoughness = material.layers.z;
  return m;
}

// KHR_materials_unlit, once the base colour is final (textures, vertex colour): the surface shows
// its base colour as it is, lit by nothing. It is stored as emission with no reflectance, so that
// every lighting technique and the forward pass show it without a branch of their own; the
// G-buffer keeps the base colour for the data views.
MaterialSample withUnlit(GpuMaterial material, MaterialSample m) {
  if ((material.flags.x & MYRIAD_MATERIAL_UNLIT) != 0u) {
    m.emissive = max(m.baseColor.rgb, vec3(0.0));
    m.reflectance = 0.0;
  }
  return m;
}

// The G-buffer's texels of a material sample, as both paths store them (formats:
// render/frame_targets.h; base colour is linear here, the sRGB encoding is the target's).
struct GBufferTexels {
  vec2 normal;     // octahedral
  vec4 baseColor;
  vec4 material;   // metallic, roughness, occlusion, specular (F90)
  vec4 emissive;   // emission, then the dielectric's F0 less glTF's 0.04 (so that the default
                   // is exact in half float), or -1 for an unlit surface
  uvec2 layers;    // packUnorm4x8(clearcoat, its roughness, sheen roughness, 0), then
                   // packUnorm4x8(sheen colour, 0): what a pixel's layers need, 8 bits each
};

GBufferTexels gbufferTexels(MaterialSample m) {
  GBufferTexels t;
  t.normal = octahedralEncode(m.normal);
  t.baseColor = vec4(clamp(m.baseColor.rgb, 0.0, 1.0), 1.0);
  t.material = clamp(vec4(m.metallic, m.roughness, m.occlusion, m.specular), 0.0, 1.0);
  t.emissive = vec4(m.emissive, m.reflectance > 0.0 ? m.dielectricF0 - 0.04 : -1.0);
  t.layers = uvec2(packUnorm4x8(vec4(m.clearcoat, m.clearcoatRoughness, m.sheenRoughness, 0.0)),
                   packUnorm4x8(vec4(m.sheenColor, 0.0)));
  return t;
}

#endif
