// The material of the surface being rasterised (glTF metallic-roughness, every texture slot),
// shared by the G-buffer pass (gbuffer.frag) and the forward pass of alpha-blended surfaces
// (forward.glsl): the vertex outputs of gbuffer.vert, set 3's textures, and evaluateMaterial().
#ifndef MYRIAD_MATERIAL_GLSL
#define MYRIAD_MATERIAL_GLSL

#include "material_core.glsl"

layout(location = 0) in vec3 inWorldPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) flat in uint inMaterial;
layout(location = 4) in vec4 inTangent;
layout(location = 5) in vec4 inColor;

layout(set = MYRIAD_SET_MATERIAL, binding = MYRIAD_BINDING_TEXTURE_BASE_COLOR) uniform sampler2D baseColorTexture;
layout(set = MYRIAD_SET_MATERIAL, binding = MYRIAD_BINDING_TEXTURE_METALLIC_ROUGHNESS) uniform sampler2D metallicRoughnessTexture;
layout(set = MYRIAD_SET_MATERIAL, binding = MYRIAD_BINDING_TEXTURE_NORMAL) uniform sampler2D normalTexture;
layout(set = MYRIAD_SET_MATERIAL, binding = MYRIAD_BINDING_TEXTURE_OCCLUSION) uniform sampler2D occlusionTexture;
layout(set = MYRIAD_SET_MATERIAL, binding = MYRIAD_BINDING_TEXTURE_EMISSIVE) uniform sampler2D emissiveTexture;

// Texture slot `slot`'s coordinates: the mesh uv through the material's KHR_texture_transform.
vec2 slotUv(GpuMaterial m, int slot) {
  vec3 uv = vec3(inUv, 1.0);
  return vec2(dot(m.uvTransform[2 * slot].xyz, uv), dot(m.uvTransform[2 * slot + 1].xyz, uv));
}

bool hasTexture(GpuMaterial m, int slot) {
#ifdef MYRIAD_MATERIAL_UNTEXTURED
  return false;  // gbuffer_untextured.frag: drawn only for materials with no texture slot
#else
  return (m.flags.x & (1u << uint(slot))) != 0u;
#endif
}

// Screen-space derivatives of the interpolated inputs, taken once at the top, in uniform control
// flow, from inputs alone. Nothing read from a buffer may feed a derivative: helper invocations
// (the pixels of a 2x2 quad outside the triangle) need not perform buffer loads (lavapipe's
// don't), so a derivative of a value computed from the material would be garbage along every
// triangle edge (it was: dotted edges sampled from the 1x1 mip).
vec2 uvDx;
vec2 uvDy;

// The derivatives of slot `slot`'s uv: the chain rule through the transform's 2x2 part.
mat2 slotJacobian(GpuMaterial m, int slot) {
  vec4 r0 = m.uvTransform[2 * slot];
  vec4 r1 = m.uvTransform[2 * slot + 1];
  return mat2(r0.x, r1.x, r0.y, r1.y);  // columns
}

vec4 sampleSlot(sampler2D tex, GpuMaterial m, int slot) {
  mat2 j = slotJacobian(m, slot);
  return textureGrad(tex, slotUv(m, slot), j * uvDx, j * uvDy);
}

MaterialSample evaluateMaterial(GpuMaterial material) {
  uvDx = dFdx(inUv);
  uvDy = dFdy(inUv);
  vec3 positionDx = dFdx(inWorldPosition);
  vec3 positionDy = dFdy(inWorldPosition);
  // Double-sided surfaces (and formats that do not say) are drawn from both sides; the back side
  // faces us, so its normal (and tangent frame) is flipped. Single-sided ones have their back
  // faces culled by the pipeline.
  float side = gl_FrontFacing ? 1.0 : -1.0;
  MaterialSample m = untexturedMaterial(material, inColor, inNormal,
                                        cross(positionDx, positionDy), side);
  if (hasTexture(material, MYRIAD_BINDING_TEXTURE_BASE_COLOR)) {
    m.baseColor *= sampleSlot(baseColorTexture, material, MYRIAD_BINDING_TEXTURE_BASE_COLOR);
  }
  vec3 n = m.normal;

  if (hasTexture(material, MYRIAD_BINDING_TEXTURE_NORMAL)) {
    vec2 uv = slotUv(material, MYRIAD_BINDING_TEXTURE_NORMAL);
    vec3 t;
    vec3 b;
    bool frame = true;
    if (inTangent.w != 0.0) {
      // The file's tangents (glTF TANGENT): bitangent = w * cross(normal, tangent), both taken
      // from the geometric side; a back face flips the whole frame (as glTF viewers do).
      vec3 ng = n * side;
      t = inTangent.xyz - ng * dot(ng, inTangent.xyz);
      frame = dot(t, t) > 1e-20;
      t = normalize(t);
      b = inTangent.w * cross(ng, t) * side;
      t *= side;
    } else {
      // None in the file: the tangent frame from screen-space derivatives of position and uv (as
      // three.js does for meshes without tangents): the surface gradients of u and v, solved from
      // the position and uv differences to the next pixel right and down. t follows +u; glTF's
      // bitangent follows -v (its uv origin is the image's top left, its normal maps' green points
      // up the image). The solve's determinant, dot(n, cross(dp1, dp2)), is negative for a front
      // face in Vulkan's y-down framebuffer: its sign is applied, or the map's relief inverts.
      vec3 dp1 = positionDx;
      vec3 dp2 = positionDy;
      mat2 j = slotJacobian(material, MYRIAD_BINDING_TEXTURE_NORMAL);
      vec2 duv1 = j * uvDx;
      vec2 duv2 = j * uvDy;
      vec3 dp2perp = cross(dp2, n);
      vec3 dp1perp = cross(n, dp1);
      float orientation = dot(n, cross(dp1, dp2)) < 0.0 ? -1.0 : 1.0;
      t = (dp2perp * duv1.x + dp1perp * duv2.x) * orientation;
      b = -(dp2perp * duv1.y + dp1perp * duv2.y) * orientation;
      frame = dot(t, t) > 1e-30 && dot(b, b) > 1e-30;
      // Geometric so far; a back face flips the frame with its normal.
      t = normalize(t) * side;
      b = normalize(b) * side;
    }
    if (frame) {
      vec3 tangentNormal = sampleSlot(normalTexture, material, MYRIAD_BINDING_TEXTURE_NORMAL).xyz * 2.0 - 1.0;
      tangentNormal.xy *= material.metallicRoughness.z;
      vec3 mapped = t * tangentNormal.x + b * tangentNormal.y + n * tangentNormal.z;
      if (dot(mapped, mapped) > 1e-12) n = normalize(mapped);
    }
  }

  m.normal = n;
  if (hasTexture(material, MYRIAD_BINDING_TEXTURE_METALLIC_ROUGHNESS)) {
    vec4 mr = sampleSlot(metallicRoughnessTexture, material, MYRIAD_BINDING_TEXTURE_METALLIC_ROUGHNESS);
    m.metallic *= mr.b;
    m.roughness *= mr.g;
  }
  if (hasTexture(material, MYRIAD_BINDING_TEXTURE_OCCLUSION)) {
    float ao = sampleSlot(occlusionTexture, material, MYRIAD_BINDING_TEXTURE_OCCLUSION).r;
    m.occlusion = 1.0 + material.metallicRoughness.w * (ao - 1.0);
  }
  if (hasTexture(material, MYRIAD_BINDING_TEXTURE_EMISSIVE)) {
    m.emissive *= sampleSlot(emissiveTexture, material, MYRIAD_BINDING_TEXTURE_EMISSIVE).rgb;
  }
  return withUnlit(material, m);
}

#endif
