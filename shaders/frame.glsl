// Declarations every pass shares: the frame uniforms, the scene buffers and the G-buffer, plus
// surface reconstruction from the G-buffer (position comes from depth; nothing stores it).
#ifndef MYRIAD_FRAME_GLSL
#define MYRIAD_FRAME_GLSL

#extension GL_EXT_control_flow_attributes : require
#include "shared_types.h"

// What this pipeline's shading may meet (MYRIAD_FEATURE_* bits, shared_types.h): every bit unless
// the pipeline is specialised for a frame's features (render/shading_features.h).
layout(constant_id = MYRIAD_SPEC_SHADING_FEATURES) const uint kShadingFeatures = MYRIAD_FEATURES_ALL;
bool shadingFeature(uint bit) { return (kShadingFeatures & bit) != 0u; }
#define MYRIAD_MAY_SPOT shadingFeature(MYRIAD_FEATURE_SPOT_LIGHTS)
#define MYRIAD_MAY_WINDOW_FALLOFF shadingFeature(MYRIAD_FEATURE_WINDOW_FALLOFF)
#define MYRIAD_MAY_INVERSE_SQUARE shadingFeature(MYRIAD_FEATURE_INVERSE_SQUARE)
#define MYRIAD_MAY_LAYERS shadingFeature(MYRIAD_FEATURE_LAYERS)
#include "shading.glsl"

#include "scene_set.glsl"
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHTS) readonly buffer LightBlock {
  GpuPointLight lights[];
};
// The same lights as texels (shared_types.h MYRIAD_BINDING_LIGHT_TEXELS says why), for the CPU
// devices' light loop (light_clustered_whole.comp): lightTexel, lightFromTexels.
layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_TEXELS) uniform samplerBuffer lightTexels;

// The environment light (shaders/environment.glsl; render/environment.cpp builds it).
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_ENVIRONMENT) readonly buffer EnvironmentBlock {
  vec4 environmentTexels[];
};
layout(std430, set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_BRDF_LUT) readonly buffer BrdfLutBlock {
  vec4 brdfLutTexels[];
};
// The sun's shadow maps (render/shadows.cpp), its cascades' tiles side by side in one atlas, a
// comparison sampler: LESS_OR_EQUAL, linear where the device filters the depth format linearly
// (then each tap is a 2x2 PCF of its own).
layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_SUN_SHADOW_MAP) uniform sampler2DShadow sunShadowMap;
// Local lights' shadow tiles, all in one atlas (render/shadows.cpp), the same sampler.
layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_LIGHT_SHADOW_ATLAS) uniform sampler2DShadow lightShadowAtlas;
#define MYRIAD_ENV_LIGHTING(i) environmentTexels[i]
#define MYRIAD_BRDF_LUT(i) brdfLutTexels[i]
#include "environment.glsl"

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_DEPTH) uniform sampler2D gbufferDepth;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_NORMAL) uniform sampler2D gbufferNormal;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_BASE_COLOR) uniform sampler2D gbufferBaseColor;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_MATERIAL) uniform sampler2D gbufferMaterial;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_UV) uniform sampler2D gbufferUv;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_HDR) uniform sampler2D hdrColor;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_LIGHT_COUNT) uniform sampler2D lightCount;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_EMISSIVE) uniform sampler2D gbufferEmissive;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_GBUFFER_LAYERS) uniform usampler2D gbufferLayers;

struct Surface {
  vec3 position;
  vec3 normal;
  vec3 baseColor;
  float metallic;
  float roughness;
  float occlusion;  // the material's ambient occlusion: scales ambient and environment light only
  vec3 emissive;    // emitted radiance, added once (sunAndAmbient)
  float reflectance;  // scales all reflected light: 1 the glTF BRDF, 0 an unlit material's none
  float dielectricF0;  // the dielectric's Fresnel at normal incidence: 0.04 at glTF's ior 1.5
  float specular;      // and at grazing incidence (KHR_materials_specular's factor, else 1)
  float clearcoat;           // KHR_materials_clearcoat's factor (0: none)
  float clearcoatRoughness;
  vec3 sheenColor;           // KHR_materials_sheen's colour (0: none)
  float sheenRoughness;
};

// Whether this frame's surfaces may have a clear coat or a sheen (a material of the scene has
// one: the layers target was written). Where not, no pixel pays for them.
bool layersOn() {
  return shadingFeature(MYRIAD_FEATURE_LAYERS) && (frame.written.x & MYRIAD_GBUFFER_LAYERS) != 0u;
}


#include "cluster_grid.glsl"  // worldFromDepth, and the cluster of a pixel

// False where no geometry was drawn (depth still at the cleared far value).
bool loadSurfaceWithDepth(ivec2 pixel, float depth, out Surface s) {
  if (depth >= 1.0) {
    return false;
  }
  s.position = worldFromDepth(pixel, depth);
  s.normal = octahedralDecode(texelFetch(gbufferNormal, pixel, 0).rg);
  s.baseColor = texelFetch(gbufferBaseColor, pixel, 0).rgb;  // sRGB format: sampled as linear
  vec4 material = texelFetch(gbufferMaterial, pixel, 0);
  s.metallic = material.x;
  s.roughness = material.y;
  s.occlusion = material.z;
  s.specular = material.w;
  // The emissive target, where a material needs it, carries the dielectric's F0 less glTF's 0.04
  // in alpha (0, exactly, for most materials: a frame that writes the target for another reason
  // shades them bit for bit as one that does not), -1 for an unlit surface (material_core.glsl's
  // gbufferTexels).
  vec4 emissive = shadingFeature(MYRIAD_FEATURE_EMISSIVE) && (frame.written.x & MYRIAD_GBUFFER_EMISSIVE) != 0u
                      ? texelFetch(gbufferEmissive, pixel, 0)
                      : vec4(0.0);
  s.emissive = emissive.rgb;
  s.reflectance = emissive.a < -0.5 ? 0.0 : 1.0;
  s.dielectricF0 = max(emissive.a + 0.04, 0.0);
  // The layers target, where a material of the scene has a clear coat or a sheen
  // (material_core.glsl's gbufferTexels).
  uvec2 layers = layersOn() ? texelFetch(gbufferLayers, pixel, 0).rg : uvec2(0u);
  vec4 coat = unpackUnorm4x8(layers.x);
  s.clearcoat = coat.x;
  s.clearcoatRoughness = coat.y;
  s.sheenRoughness = coat.z;
  s.sheenColor = unpackUnorm4x8(layers.y).rgb;
  return true;
}

bool loadSurface(ivec2 pixel, out Surface s) {
  return loadSurfaceWithDepth(pixel, texelFetch(gbufferDepth, pixel, 0).r, s);
}

// What shadeLight works out per light from the surface and the view alone, for a pass that
// shades many lights at one point (shadeLightAt).
BrdfSurface brdfSurfaceOf(Surface s) {
  BrdfSurface b = brdfSurface(s.normal, normalize(frame.cameraPosition.xyz - s.position),
                              s.baseColor, s.metallic, s.roughness);
  // The dielectric's Fresnel from its F0 and F90 (KHR_materials_ior and _specular: glTF's 0.04
  // and 1 by default, which leave b as it is); the metal's is its base colour to 1. Then the
  // reflectance scales what the surface reflects (brdfCosineAt is linear in F0, 1 - F0 and the
  // diffuse term): 0 for an unlit surface.
  b.F0 = mix(vec3(s.dielectricF0), s.baseColor, s.metallic) * s.reflectance;
  b.oneMinusF0 = mix(vec3(s.specular), vec3(1.0), s.metallic) * s.reflectance - b.F0;
  b.diffuseColor *= s.reflectance;
  b.diffuseOverPi *= s.reflectance;
  if (layersOn()) {
    b = withLayers(b, s.clearcoat, s.clearcoatRoughness, s.sheenColor, s.sheenRoughness);
  }
  return b;
}


bool environmentOn() {
  return shadingFeature(MYRIAD_FEATURE_ENVIRONMENT) && frame.environment.x != float(MYRIAD_ENV_NONE);
}

// The sun's shadow cascade for a surface point: the first whose far end (view depth; render/
// cascades.cpp fitSunCascades, splitFar) reaches past the point, the last beyond them all; -1 when
// the sun casts no shadows.
//
// The cascades' loops read each cascade's parameters at a run-time index ([[dont_unroll]]),
// sunCascade[c].w saying whether cascade c is in use, and branch on nothing read from `frame` at
// a fixed place: lavapipe (Mesa 22.3) replaces a uniform that decides a branch by its value and,
// when that removes half of a shader, compiles the shader again at every bind, keeping every copy
// until the pipeline goes (a 4096^2 raw frame's views pass grew the host's memory ~10 MiB a
// frame; CTest api "host memory"). A load at an index known only when the shader runs is never
// replaced.
int sunShadowCascade(vec3 position) {
  if (!shadingFeature(MYRIAD_FEATURE_SUN_SHADOW)) {
    return -1;
  }
  float viewDepth = -(frame.view * vec4(position, 1.0)).z;
  int cascade = -1;
  int last = -1;
  [[dont_unroll]] for (int c = 0; c < MYRIAD_MAX_SUN_CASCADES; ++c) {
    vec4 params = frame.sunCascade[c];
    if (params.w > 0.5) {
      last = c;
      if (cascade < 0 && viewDepth <= params.z) {
        cascade = c;
      }
    }
  }
  return cascade < 0 ? last : cascade;
}

// How much of the sun reaches a surface point through cascade `cascade` (sunShadowCascade): 1
// lit, 0 in shadow, between in the penumbra. 3x3 taps a texel apart (percentage-closer filtering,
// Reeves et al. 1987), so the penumbra is about three texels wide. Acne is kept off by a normal
// offset (Holbein 2011: the point moves along its normal by more the more the surface grazes the
// light, where its texels stretch) plus a depth bias of 1.5 texels of depth, more on slopes
// (2 tan(theta), at most 10 more: the 3x3 taps reach a texel away, where a sloped receiver is that
// much nearer the light); both are the cascade's own texel. The cascades live side by side in one
// atlas; taps are clamped inside the cascade's tile, so a cascade never reads its neighbour's
// depth. A point outside its cascade's square (only the normal offset can push it out: each
// cascade's square holds its part of the view) tries the next cascade; outside them all, or
// past the map's depth, the sun is unoccluded. (Its loop as sunShadowCascade's, for lavapipe.)
float sunShadowFactorIn(int cascade, vec3 position, vec3 normal) {
  if (cascade < 0) {
    return 1.0;
  }
  float cosTheta = dot(normal, frame.sunDirection.xyz);
  if (cosTheta <= 0.0) {
    return 1.0;  // facing away: the sun adds nothing here whatever the map says
  }
  float sinTheta = sqrt(max(1.0 - cosTheta * cosTheta, 0.0));
  float tileTexels = frame.sunShadow.y;
  vec2 grid = frame.sunShadow.zw;
  float edge = 1.0 / tileTexels;  // a texel in from the tile's border: the 2x2 filter stays inside
  [[dont_unroll]] for (int c = cascade; c < MYRIAD_MAX_SUN_CASCADES; ++c) {
    vec4 cascadeParams = frame.sunCascade[c];
    if (cascadeParams.w < 0.5) {
      break;  // past the frame's cascades
    }
    vec3 p = position + normal * (cascadeParams.x * (0.5 + sinTheta));
    vec3 map = (frame.sunShadowMatrix[c] * vec4(p, 1.0)).xyz;
    if (map.x < edge || map.x > 1.0 - edge || map.y < edge || map.y > 1.0 - edge) {
      continue;
    }
    if (map.z > 1.0) {
      return 1.0;
    }
    float reference = map.z - cascadeParams.y * (1.5 + min(2.0 * sinTheta / cosTheta, 10.0));
    vec2 tile = vec2(float(c % int(grid.x)), float(c / int(grid.x)));
    float lit = 0.0;
    for (int y = -1; y <= 1; ++y) {
      for (int x = -1; x <= 1; ++x) {
        vec2 uv = clamp(map.xy + vec2(float(x), float(y)) / tileTexels, vec2(edge), vec2(1.0 - edge));
        lit += textureLod(sunShadowMap, vec3((tile + uv) / grid, reference), 0.0);
      }
    }
    return lit / 9.0;
  }
  return 1.0;
}

float sunShadowFactor(vec3 position, vec3 normal) {
  return sunShadowFactorIn(sunShadowCascade(position), position, normal);
}

// What every technique adds once per pixel besides its local lights: the sun, either the constant
// ambient term (environment "none") or the environment light, both scaled by the material's
// occlusion, and the surface's own emission. Every technique calls this, so they agree exactly;
// the C++ reference makes the same calls.
vec3 sunAndAmbient(Surface s) {
  BrdfSurface b = brdfSurfaceOf(s);
  vec3 sun = frame.sunColor.rgb * (frame.sunDirection.w * sunShadowFactor(s.position, s.normal));
  vec3 color = brdfCosineAt(b, frame.sunDirection.xyz) * sun;
  if (!environmentOn()) {
    // The BRDF's hemispherical integral under constant radiance, roughly (shadeSunAndAmbient).
    vec3 ambient = frame.ambient.rgb * s.occlusion;
    color += ambientThroughLayers(b, ambient * (b.diffuseColor + b.F0), ambient);
  } else {
    vec3 base = shadeEnvironmentWith(b.N, b.V, b.diffuseColor, b.F0, b.F0 + b.oneMinusF0,
                                     s.roughness, s.occlusion, frame.environmentRotation.x,
                                     frame.environmentRotation.y, frame.environment.y);
    color += environmentThroughLayers(b, base, s.occlusion, frame.environmentRotation.x,
                                      frame.environmentRotation.y, frame.environment.y);
  }
  // A model's directional lights besides the sun (intensity 0: none).
  for (int i = 0; i < MYRIAD_MAX_EXTRA_SUNS && shadingFeature(MYRIAD_FEATURE_EXTRA_SUNS); ++i) {
    if (frame.extraSunDirection[i].w > 0.0) {
      color += brdfCosineAt(b, frame.extraSunDirection[i].xyz) *
               (frame.extraSunColor[i].rgb * frame.extraSunDirection[i].w);
    }
  }
  return color + throughLayers(b, s.emissive);  // emission lies under the coat
}

// What a pixel with no geometry shows: the environment seen through it when the environment is
// on and shown as the background, else the background colour.
vec3 backgroundRadiance(ivec2 pixel) {
  if (!environmentOn() || frame.environment.z == 0.0) {
    return frame.background.rgb;
  }
  vec3 d = normalize(worldFromDepth(pixel, 1.0) - frame.cameraPosition.xyz);
  return environmentBackground(d, frame.environmentRotation.x, frame.environmentRotation.y,
                               frame.environment.y);
}

vec3 spotDirectionOf(GpuPointLight light) {
  return octahedralDecode(light.cone.xy);
}

// The shadow-map slot of light `index` this frame, or -1 (most lights: then nothing changes).
int lightShadowSlot(uint index) {
  for (uint i = 0u; i < frame.lightShadows.x; ++i) {
    if (frame.shadowedLightIndex[i >> 2u][i & 3u] == index) {
      return int(i);
    }
  }
  return -1;
}

// The cube faces' axes, as render/shadows.cpp renders them (glm::lookAt(eye, eye + forward, up)):
// the tile's u runs along cross(forward, up), its v along the view's up.
vec3 cubeFaceForward(uint face) {
  vec3 forward = vec3(0.0);
  forward[face >> 1u] = (face & 1u) == 0u ? 1.0 : -1.0;  // +X -X +Y -Y +Z -Z
  return forward;
}
vec3 cubeFaceUp(uint face) {
  return (face >> 1u) == 1u ? vec3(0, 0, 1) : vec3(0, 1, 0);  // +Z for the Y faces, else +Y
}

// How much of shadowed light `slot` reaches a surface point: 1 lit, 0 occluded. The sun's scheme
// (sunShadowFactor) in a perspective map: 3x3 PCF, a normal offset and a depth bias both sized to
// one texel at the point's distance from the light (plus the slope term), the bias in world units
// along the tile's axis. Taps stay inside the tile (clamped half a texel in), so a tile never
// reads its neighbour's depth.
float localShadowFactor(int slot, vec3 position, vec3 normal) {
  GpuLightShadow ls = frame.lightShadow[slot];
  vec3 toLight = ls.positionNear.xyz - position;
  float distance = length(toLight);
  if (distance <= 0.0) {
    return 1.0;
  }
  float cosTheta = dot(normal, toLight / distance);
  if (cosTheta <= 0.0) {
    return 1.0;  // facing away: the light adds nothing here whatever the map says
  }
  float sinTheta = sqrt(max(1.0 - cosTheta * cosTheta, 0.0));
  float texel = ls.params.y * distance;  // one texel's width in world units, here
  vec3 v = position + normal * (texel * (0.5 + sinTheta)) - ls.positionNear.xyz;
  uint tile = ls.tiles.x;
  vec2 uv;
  float d;
  if (ls.tiles.y == MYRIAD_LIGHT_SHADOW_SPOT) {
    vec4 clip = ls.mapFromWorld * vec4(v + ls.positionNear.xyz, 1.0);
    d = clip.w;
    if (d <= 0.0) {
      return 1.0;
    }
    uv = clip.xy / clip.w * 0.5 + 0.5;
    if (uv.x < 0.0 || uv.x > 1.0 || uv.y < 0.0 || uv.y > 1.0) {
      return 1.0;  // outside the map is outside the cone: the light adds nothing there
    }
  } else {
    vec3 a = abs(v);
    uint face = a.x >= a.y && a.x >= a.z ? (v.x >= 0.0 ? 0u : 1u)
                                         : (a.y >= a.z ? (v.y >= 0.0 ? 2u : 3u) : (v.z >= 0.0 ? 4u : 5u));
    vec3 forward = cubeFaceForward(face);
    vec3 side = cross(forward, cubeFaceUp(face));
    vec3 up = cross(side, forward);
    d = dot(v, forward);
    uv = vec2(dot(v, side), dot(v, up)) / d * 0.5 + 0.5;
    tile += face;
  }
  float near = ls.positionNear.w, far = ls.params.x;
  if (d >= far) {
    return 1.0;
  }
  float biased = max(d - texel * (1.5 + min(2.0 * sinTheta / cosTheta, 10.0)), near);
  float reference = far / (far - near) * (1.0 - near / biased);
  float tileTexels = float(frame.lightShadows.y);
  vec2 origin = vec2(float(tile % MYRIAD_SHADOW_ATLAS_COLUMNS), float(tile / MYRIAD_SHADOW_ATLAS_COLUMNS)) * tileTexels;
  vec2 atlasTexel = 1.0 / vec2(frame.lightShadows.zw);
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y) {
    for (int x = -1; x <= 1; ++x) {
      vec2 inTile = clamp(uv * tileTexels + vec2(float(x), float(y)), vec2(0.5), vec2(tileTexels - 0.5));
      lit += textureLod(lightShadowAtlas, vec3((origin + inTile) * atlasTexel, reference), 0.0);
    }
  }
  return lit / 9.0;
}

// Member `member` (0 positionRadius, 1 radianceFalloff, 2 cone) of light `index`, from lightTexels.
vec4 lightTexel(uint index, uint member) {
  return texelFetch(lightTexels, int(index * MYRIAD_LIGHT_TEXELS + member));
}

GpuPointLight lightFromTexels(uint index) {
  GpuPointLight light;
  light.positionRadius = lightTexel(index, 0u);
  light.radianceFalloff = lightTexel(index, 1u);
  light.cone = lightTexel(index, 2u);
  return light;
}

// shadeLight for a light already loaded.
vec3 shadeLightData(Surface s, GpuPointLight light) {
  return shadeLocalLightAt(brdfSurfaceOf(s), s.position, light.positionRadius.xyz,
                           light.positionRadius.w, light.radianceFalloff.rgb,
                           light.radianceFalloff.w, spotDirectionOf(light), light.cone.z,
                           light.cone.w);
}

vec3 shadeLight(Surface s, uint index) {
  return shadeLightData(s, lights[index]);
}

// shadeLight with brdfSurfaceOf(s) worked out once: b.
vec3 shadeLightAt(BrdfSurface b, Surface s, uint index) {
  GpuPointLight light = lights[index];
  return shadeLocalLightAt(b, s.position, light.positionRadius.xyz, light.positionRadius.w,
                           light.radianceFalloff.rgb, light.radianceFalloff.w,
                           spotDirectionOf(light), light.cone.z, light.cone.w);
}

// shadeLight with the light's shadow map applied when it has one this frame: for a pass that
// shades one light (the volumes technique's light fragments).
vec3 shadeLightShadowed(Surface s, uint index) {
  vec3 c = shadeLight(s, index);
  if (shadingFeature(MYRIAD_FEATURE_LOCAL_SHADOWS) && frame.lightShadows.x != 0u) {
    int slot = lightShadowSlot(index);
    if (slot >= 0) {
      c *= localShadowFactor(slot, s.position, s.normal);
    }
  }
  return c;
}

// Whether the surface point is inside the light's radius (its positionRadius): lightReaches' first
// test, for the CPU loop that loads the light from its texels.
bool withinLightRadius(Surface s, vec4 positionRadius) {
  vec3 toLight = positionRadius.xyz - s.position;
  return dot(toLight, toLight) < positionRadius.w * positionRadius.w;
}

// lightReaches for a light already loaded, past withinLightRadius: its cone.
bool lightDataReaches(Surface s, GpuPointLight light) {
  return localLightReaches(s.position, light.positionRadius.xyz, light.positionRadius.w,
                           spotDirectionOf(light), light.cone.z);
}

// Whether the light reaches the surface point at all: inside its radius and its outer cone (what
// the light-count view counts; shadeLight is exactly 0 wherever this is false).
// The radius test runs first on the light's first 16 bytes alone: with long lists most lights fail
// it, and they need neither their cone nor its decoding.
// (Its radius test is written out, not withinLightRadius: through the negated form the H200's
// 10,000-light shade pass took 0.427 ms at 1080p and 1.536 at 4K, against 0.413 and 1.472 written
// out, alternated in one run; bench/results/2026-12-03-h200-stop20.)
bool lightReaches(Surface s, uint index) {
  vec4 positionRadius = lights[index].positionRadius;
  vec3 toLight = positionRadius.xyz - s.position;
  if (dot(toLight, toLight) >= positionRadius.w * positionRadius.w) {
    return false;
  }
  GpuPointLight light = lights[index];
  return lightDataReaches(s, light);
}

// For the passes that sum shadeLight over a list of lights (tiled, clustered, the blend pass):
// `color` with the occluded part of each shadowed light taken out, once per pixel after the loop.
// A light reaching the point is in every list (the lists are exact), so its unshadowed term is in
// the sum and shadeLight * (1 - factor) comes off it. Kept out of the per-light loop on purpose:
// the shadow lookup inside it made llvmpipe's lighting 2.3x slower even with no shadowed light.
vec3 withLocalShadows(Surface s, vec3 color) {
  if (!shadingFeature(MYRIAD_FEATURE_LOCAL_SHADOWS)) {
    return color;
  }
  for (uint i = 0u; i < frame.lightShadows.x; ++i) {
    uint index = frame.shadowedLightIndex[i >> 2u][i & 3u];
    if (lightReaches(s, index)) {
      float lit = localShadowFactor(int(i), s.position, s.normal);
      if (lit < 1.0) color -= shadeLight(s, index) * (1.0 - lit);
    }
  }
  return max(color, vec3(0.0));
}

// The view-space box around the frustum segment of the screen rectangle [pixelLo, pixelHi)
// between view depths z0 < z1: the bounds of its eight corners (view space looks down -z).
void viewBoxOfRect(vec2 pixelLo, vec2 pixelHi, float z0, float z1, out vec3 lo, out vec3 hi) {
  vec2 size = frame.viewport.xy;
  vec2 ndc0 = pixelLo / size * 2.0 - 1.0;
  vec2 ndc1 = pixelHi / size * 2.0 - 1.0;
  vec2 scale = vec2(1.0 / frame.projection[0][0], 1.0 / frame.projection[1][1]);
  // projection[2].xy: a jittered projection's NDC offset (TAA's sub-frames; 0 otherwise).
  vec2 offset = vec2(frame.projection[2][0], frame.projection[2][1]);
  vec2 a0 = (ndc0 + offset) * scale, a1 = (ndc1 + offset) * scale;  // view x/y per unit depth
  vec2 xyLo = min(min(a0 * z0, a0 * z1), min(a1 * z0, a1 * z1));
  vec2 xyHi = max(max(a0 * z0, a0 * z1), max(a1 * z0, a1 * z1));
  lo = vec3(xyLo, -z1);
  hi = vec3(xyHi, -z0);
}

// The view-space box of cluster (x, y, slice).
void clusterViewBox(uvec3 c, out vec3 lo, out vec3 hi) {
  float z0 = c.z == 0u ? frame.camera.y : viewDepthOfSlice(c.z);
  float z1 = c.z + 1u == frame.grid.z ? frame.camera.z : viewDepthOfSlice(c.z + 1u);
  vec2 pixelLo = vec2(c.xy * clusterTileSize());
  vec2 pixelHi = vec2(min((c.xy + 1u) * clusterTileSize(), uvec2(frame.viewport.xy)));
  viewBoxOfRect(pixelLo, pixelHi, z0, z1, lo, hi);
}

// Whether a sphere (view-space centre c, radius r) overlaps the box [lo, hi].
bool sphereOverlapsBox(vec3 c, float r, vec3 lo, vec3 hi) {
  vec3 d = clamp(c, lo, hi) - c;
  return dot(d, d) <= r * r;
}

vec3 viewVector(vec3 position) {
  return normalize(frame.cameraPosition.xyz - position);
}

#endif
