#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) in vec3 inWorldPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) flat in uint inMaterial;

layout(location = 0) out vec2 outNormal;     // octahedral, RG16_SNORM
layout(location = 1) out vec4 outBaseColor;  // RGBA8_SRGB
layout(location = 2) out vec2 outMaterial;   // metallic, roughness: RG8_UNORM
layout(location = 3) out vec2 outUv;         // RG16_SFLOAT

void main() {
  vec3 n = inNormal;
  // Broken models (zero or NaN normals) still get a usable normal: the triangle's own.
  if (!(dot(n, n) > 1e-12)) {
    n = cross(dFdx(inWorldPosition), dFdy(inWorldPosition));
  }
  n = normalize(n);
  // Models disagree about winding, so the G-buffer draws both sides; the back side faces us.
  if (!gl_FrontFacing) {
    n = -n;
  }
  GpuMaterial material = materials[inMaterial];
  outNormal = octahedralEncode(n);
  outBaseColor = vec4(material.baseColor.rgb, 1.0);
  outMaterial = material.metallicRoughness.xy;
  outUv = inUv;
}
