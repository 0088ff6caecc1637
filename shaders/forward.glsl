// The forward pass of alpha-blended (glTF alphaMode BLEND) surfaces, after lighting: the material
// as the G-buffer pass evaluates it (material.glsl), lit as every technique lights an opaque pixel
// (sunAndAmbient: the suns, ambient or environment, emission; then the local lights with the
// exact reach test), written with alpha for `over` blending into hdr. Two variants:
// forward_clustered.frag walks the clustered technique's list for the fragment's cluster (the
// technique marked the clusters blended fragments fall in); forward.frag (volumes, tiled, or a
// device without fragmentStoresAndAtomics) tests every light.
#include "frame.glsl"
#include "material.glsl"

#ifdef MYRIAD_FORWARD_CLUSTERED
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_RANGES) readonly buffer ClusterRangeBlock {
  uvec2 clusterRanges[];
};
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_LIGHTS) readonly buffer ClusterLightBlock {
  uint clusterLights[];
};
#endif

layout(location = 0) out vec4 outColor;

void main() {
  GpuMaterial material = materials[inMaterial];
  MaterialSample m = evaluateMaterial(material);
  Surface s;
  s.position = inWorldPosition;
  s.normal = m.normal;
  s.baseColor = clamp(m.baseColor.rgb, 0.0, 1.0);
  s.metallic = clamp(m.metallic, 0.0, 1.0);
  s.roughness = clamp(m.roughness, 0.0, 1.0);
  s.occlusion = clamp(m.occlusion, 0.0, 1.0);
  s.emissive = m.emissive;
  s.reflectance = m.reflectance;
  s.dielectricF0 = m.dielectricF0;
  s.specular = m.specular;
  s.clearcoat = clamp(m.clearcoat, 0.0, 1.0);
  s.clearcoatRoughness = clamp(m.clearcoatRoughness, 0.0, 1.0);
  s.sheenColor = clamp(m.sheenColor, 0.0, 1.0);
  s.sheenRoughness = clamp(m.sheenRoughness, 0.0, 1.0);
  vec3 color = sunAndAmbient(s);
#ifdef MYRIAD_FORWARD_CLUSTERED
  uvec2 tile = uvec2(gl_FragCoord.xy) / clusterTileSize();
  uint cluster = clusterIndex(uvec3(tile, sliceOfViewDepth(viewDepthFromDepth(gl_FragCoord.z))));
  uvec2 range = clusterRanges[cluster];
  for (uint i = 0u; i < range.y; ++i) {
    uint index = clusterLights[range.x + i];
    if (lightReaches(s, index)) color += shadeLight(s, index);
  }
#else
  for (uint index = 0u; index < frame.flags.y; ++index) {
    if (lightReaches(s, index)) color += shadeLight(s, index);
  }
#endif
  color = withLocalShadows(s, color);
  outColor = vec4(color, clamp(m.baseColor.a, 0.0, 1.0));
}
