#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

layout(location = 0) out vec4 outColor;  // RGBA8_UNORM; this shader does the sRGB encoding

// View depth from a [0,1] depth value of the right-handed zero-to-one projection.
float linearDepth(float depth) {
  float n = frame.camera.y;
  float f = frame.camera.z;
  return n * f / (f - depth * (f - n));
}

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  uint view = frame.flags.x;
  if (view == MYRIAD_VIEW_FINAL || view == MYRIAD_VIEW_LIGHT_VOLUMES) {
    vec3 hdr = texelFetch(hdrColor, pixel, 0).rgb;
    vec3 color = srgbEncode3(tonemapPbrNeutral(hdr * frame.camera.x));
    // The light-volumes view dims the picture so the overlay drawn next stands out.
    outColor = vec4(view == MYRIAD_VIEW_FINAL ? color : color * 0.5, 1.0);
    return;
  }

  float depth = texelFetch(gbufferDepth, pixel, 0).r;
  if (view == MYRIAD_VIEW_DEPTH) {
    float n = frame.camera.y;
    float f = frame.camera.z;
    float d = depth >= 1.0 ? 1.0 : clamp((linearDepth(depth) - n) / (f - n), 0.0, 1.0);
    outColor = vec4(vec3(d), 1.0);
    return;
  }
  if (depth >= 1.0) {
    outColor = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  vec3 color = vec3(0.0);
  if (view == MYRIAD_VIEW_ALBEDO) {
    color = srgbEncode3(texelFetch(gbufferBaseColor, pixel, 0).rgb);
  } else if (view == MYRIAD_VIEW_NORMAL) {
    color = octahedralDecode(texelFetch(gbufferNormal, pixel, 0).rg) * 0.5 + 0.5;
  } else if (view == MYRIAD_VIEW_POSITION) {
    vec3 extent = max(frame.boundsMax.xyz - frame.boundsMin.xyz, vec3(1e-6));
    color = clamp((worldFromDepth(pixel, depth) - frame.boundsMin.xyz) / extent, 0.0, 1.0);
  } else if (view == MYRIAD_VIEW_UV) {
    color = vec3(fract(texelFetch(gbufferUv, pixel, 0).rg), 0.0);
  } else if (view == MYRIAD_VIEW_METALLIC) {
    color = vec3(texelFetch(gbufferMaterial, pixel, 0).r);
  } else if (view == MYRIAD_VIEW_ROUGHNESS) {
    color = vec3(texelFetch(gbufferMaterial, pixel, 0).g);
  }
  outColor = vec4(color, 1.0);
}
