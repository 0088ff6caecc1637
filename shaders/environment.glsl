// The environment light (image-based lighting), written once in the common subset of GLSL 4.50
// and C++20/GLM, under the same rules as shading.glsl (which must be included first): the compute
// passes of render/environment.cpp and the lighting shaders include it, and the C++ reference
// (render/reference.cpp, through render/shading.h) runs the very same functions, so it builds the
// same maps with the same sample pattern and samples them with the same filtering.
//
// Data lives in vec4 storage arrays reached through macros each includer defines:
//   MYRIAD_ENV_SOURCE(i)   the source radiance pyramid (MYRIAD_ENV_SOURCE_TEXELS texels)
//   MYRIAD_ENV_LIGHTING(i) SH9 irradiance (MYRIAD_ENV_HEADER vec4s) + the prefiltered levels
//   MYRIAD_BRDF_LUT(i)     the split-sum BRDF table
// Functions that read one are compiled only where its macro is defined.
//
// Layout: every map is equirectangular, u = 0.5 + atan(x, -z) / 2pi (u = 0.5 looks down -Z),
// v = acos(y) / pi (v = 0 is straight up); rows top first, texel (i, j) at offset + j * width + i.

#ifndef MYRIAD_ENVIRONMENT_GLSL
#define MYRIAD_ENVIRONMENT_GLSL

// ---- Directions.

vec2 equirectFromDirection(vec3 d) {
  // atan(0, 0) is undefined in GLSL: at the poles any longitude will do.
  float u = abs(d.x) + abs(d.z) > 1e-12f ? 0.5f + atan(d.x, -d.z) * (0.5f / kPi) : 0.5f;
  float v = acos(clamp(d.y, -1.0f, 1.0f)) * (1.0f / kPi);
  return vec2(u, v);
}

vec3 directionFromEquirect(float u, float v) {
  float phi = (u - 0.5f) * (2.0f * kPi);
  float theta = v * kPi;
  float s = sin(theta);
  return vec3(s * sin(phi), cos(theta), -s * cos(phi));
}

// Rotation about +Y by the angle whose cosine and sine are c and s (right-handed: +X towards -Z).
vec3 rotateAboutY(vec3 d, float c, float s) {
  return vec3(c * d.x + s * d.z, d.y, c * d.z - s * d.x);
}

// ---- The procedural sky (mode "sky"). Radiance seen along unit direction d, for a sun towards
// unit vector toSun with linear colour sunColor (its intensity does not enter: the sky stays lit
// with the sun's direct light off). With y = d.y and e = toSun.y (the sun's elevation, as a sine):
//   day     = 0.03 + 0.97 * smoothstep(-0.15, 0.25, e)                 (night keeps 3%)
//   horizon = mix((0.70, 0.78, 0.88), (0.95, 0.55, 0.30), 1 - smoothstep(0.0, 0.35, e))
//   above   = mix(horizon, zenith (0.18, 0.36, 0.80), sqrt(y))                 for y >= 0
//   below   = mix(horizon, ground (0.20, 0.18, 0.16), 1 - exp(8 y)) * 0.6      for y < 0
//   glow    = (0.6 g^8 + 3 g^64) * smoothstep(-0.1, 0.05, e),   g = max(dot(d, toSun), 0)
//   sky     = (gradient * day + glow) * sunColor
// The sun's disc itself is left out: the sun light draws it (a delta no 256x128 map could hold).
vec3 skyRadiance(vec3 d, vec3 toSun, vec3 sunColor) {
  float e = clamp(toSun.y, -1.0f, 1.0f);
  float day = 0.03f + 0.97f * smoothstep(-0.15f, 0.25f, e);
  vec3 horizon = mix(vec3(0.70f, 0.78f, 0.88f), vec3(0.95f, 0.55f, 0.30f),
                     1.0f - smoothstep(0.0f, 0.35f, e));
  vec3 zenith = vec3(0.18f, 0.36f, 0.80f);
  vec3 ground = vec3(0.20f, 0.18f, 0.16f);
  float y = clamp(d.y, -1.0f, 1.0f);
  vec3 gradient = y >= 0.0f ? mix(horizon, zenith, sqrt(y))
                            : mix(horizon, ground, 1.0f - exp(8.0f * y)) * 0.6f;
  float g = max(dot(d, toSun), 0.0f);
  float glow = (0.6f * pow(g, 8.0f) + 3.0f * pow(g, 64.0f)) * smoothstep(-0.1f, 0.05f, e);
  return (gradient * day + vec3(glow)) * sunColor;
}

// Texel (x, y) of the sky at source level 0.
vec3 skyTexel(uint x, uint y, vec3 toSun, vec3 sunColor) {
  vec3 d = directionFromEquirect((float(x) + 0.5f) / float(MYRIAD_ENV_SOURCE_WIDTH),
                                 (float(y) + 0.5f) / float(MYRIAD_ENV_SOURCE_HEIGHT));
  return skyRadiance(d, toSun, sunColor);
}

// ---- Bilinear taps on an equirectangular level: u wraps (longitude), v clamps (the poles).

struct Bilinear {
  uint i00;
  uint i10;
  uint i01;
  uint i11;
  float fx;
  float fy;
};

Bilinear bilinearTaps(uint offset, uint width, uint height, vec2 uv, bool wrapU) {
  float x = uv.x * float(width) - 0.5f;
  float y = uv.y * float(height) - 0.5f;
  float x0f = floor(x);
  float y0f = floor(y);
  int x0 = int(x0f);
  int y0 = int(y0f);
  int w = int(width);
  int h = int(height);
  int xa = x0;
  int xb = x0 + 1;
  if (wrapU) {
    xa = xa < 0 ? xa + w : (xa >= w ? xa - w : xa);
    xb = xb < 0 ? xb + w : (xb >= w ? xb - w : xb);
  }
  xa = clamp(xa, 0, w - 1);
  xb = clamp(xb, 0, w - 1);
  int ya = clamp(y0, 0, h - 1);
  int yb = clamp(y0 + 1, 0, h - 1);
  Bilinear b;
  b.i00 = offset + uint(ya * w + xa);
  b.i10 = offset + uint(ya * w + xb);
  b.i01 = offset + uint(yb * w + xa);
  b.i11 = offset + uint(yb * w + xb);
  b.fx = clamp(x - x0f, 0.0f, 1.0f);
  b.fy = clamp(y - y0f, 0.0f, 1.0f);
  return b;
}

#define MYRIAD_BILINEAR(FETCH, b) \
  mix(mix(FETCH(b.i00), FETCH(b.i10), b.fx), mix(FETCH(b.i01), FETCH(b.i11), b.fx), b.fy)

// ---- Sampling (Hammersley points, GGX half vectors).

float radicalInverse(uint bits) {
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  return float(bits) * 2.3283064365386963e-10f;
}

// A GGX-distributed half vector around +Z for the i-th of n Hammersley points (alpha = roughness^2).
vec3 ggxHalfVector(uint i, uint n, float alpha) {
  float xi1 = (float(i) + 0.5f) / float(n);
  float xi2 = radicalInverse(i);
  float phi = 2.0f * kPi * xi1;
  float cosTheta = sqrt((1.0f - xi2) / (1.0f + (alpha * alpha - 1.0f) * xi2));
  float sinTheta = sqrt(max(1.0f - cosTheta * cosTheta, 0.0f));
  return vec3(sinTheta * cos(phi), sinTheta * sin(phi), cosTheta);
}

// The BRDF integration table (split sum, Karis 2013) for the glTF BRDF of shading.glsl: at
// N.V = nDotV and perceptual roughness `perceptual`, the specular integral is F0 * x + y.
vec2 integrateBrdf(float nDotV, float perceptual) {
  float alpha = clamp(perceptual, kMinRoughness, 1.0f);
  alpha = alpha * alpha;
  float alpha2 = alpha * alpha;
  vec3 V = vec3(sqrt(max(1.0f - nDotV * nDotV, 0.0f)), 0.0f, nDotV);
  float visV = nDotV + sqrt(alpha2 + (1.0f - alpha2) * nDotV * nDotV);
  float a = 0.0f;
  float b = 0.0f;
  for (uint i = 0u; i < uint(MYRIAD_BRDF_LUT_SAMPLES); ++i) {
    vec3 H = ggxHalfVector(i, uint(MYRIAD_BRDF_LUT_SAMPLES), alpha);
    float vDotH = clamp(dot(V, H), 0.0f, 1.0f);
    vec3 L = H * (2.0f * vDotH) - V;
    float nDotL = L.z;
    float nDotH = clamp(H.z, 0.0f, 1.0f);
    if (nDotL > 0.0f && nDotH > 0.0f) {
      float visL = nDotL + sqrt(alpha2 + (1.0f - alpha2) * nDotL * nDotL);
      // f * cos / pdf with pdf = D N.H / (4 V.H): D cancels.
      float weight = 4.0f * nDotL * vDotH / (visL * visV * nDotH);
      float fc = pow(1.0f - vDotH, 5.0f);
      a += (1.0f - fc) * weight;
      b += fc * weight;
    }
  }
  return vec2(a, b) * (1.0f / float(MYRIAD_BRDF_LUT_SAMPLES));
}

vec2 brdfLutTexel(uint x, uint y) {
  return integrateBrdf((float(x) + 0.5f) / float(MYRIAD_BRDF_LUT_SIZE),
                       (float(y) + 0.5f) / float(MYRIAD_BRDF_LUT_SIZE));
}

// ---- SH9 (real spherical harmonics, bands 0-2) of a unit direction.
float shBasis(uint k, vec3 d) {
  if (k == 0u) return 0.282095f;
  if (k == 1u) return 0.488603f * d.y;
  if (k == 2u) return 0.488603f * d.z;
  if (k == 3u) return 0.488603f * d.x;
  if (k == 4u) return 1.092548f * d.x * d.y;
  if (k == 5u) return 1.092548f * d.y * d.z;
  if (k == 6u) return 0.315392f * (3.0f * d.z * d.z - 1.0f);
  if (k == 7u) return 1.092548f * d.x * d.z;
  return 0.546274f * (d.x * d.x - d.y * d.y);
}

// Cosine-lobe convolution over pi (Ramamoorthi and Hanrahan 2001), so that the SH sum is the
// outgoing radiance of a white Lambertian surface: 1, 2/3, 1/4 for bands 0, 1, 2.
float shBandScale(uint k) {
  return k == 0u ? 1.0f : (k < 4u ? 2.0f / 3.0f : 0.25f);
}

uint envSourceOffset(uint level) {
  uint offset = 0u;
  for (uint k = 0u; k < level; ++k) {
    offset += (uint(MYRIAD_ENV_SOURCE_WIDTH) >> k) * (uint(MYRIAD_ENV_SOURCE_HEIGHT) >> k);
  }
  return offset;
}

#ifdef MYRIAD_ENV_SOURCE
#define MYRIAD_ENV_SOURCE_RGB(i) vec3(MYRIAD_ENV_SOURCE(i))

// Bilinear within pyramid level `level`.
vec3 sampleSourceLevel(vec3 d, uint level) {
  Bilinear b = bilinearTaps(envSourceOffset(level), uint(MYRIAD_ENV_SOURCE_WIDTH) >> level,
                            uint(MYRIAD_ENV_SOURCE_HEIGHT) >> level, equirectFromDirection(d), true);
  return MYRIAD_BILINEAR(MYRIAD_ENV_SOURCE_RGB, b);
}

// Trilinear: bilinear in the two pyramid levels around `lod`, blended.
vec3 sampleSource(vec3 d, float lod) {
  float l = clamp(lod, 0.0f, float(MYRIAD_ENV_SOURCE_LEVELS - 1));
  uint l0 = uint(floor(l));
  uint l1 = min(l0 + 1u, uint(MYRIAD_ENV_SOURCE_LEVELS - 1));
  vec3 a = sampleSourceLevel(d, l0);
  return l1 == l0 ? a : mix(a, sampleSourceLevel(d, l1), l - float(l0));
}

// Texel (x, y) of source level `level` (>= 1): the mean of the 2x2 texels above it.
vec3 downsampleTexel(uint level, uint x, uint y) {
  uint above = envSourceOffset(level - 1u);
  uint w = uint(MYRIAD_ENV_SOURCE_WIDTH) >> (level - 1u);
  uint i = above + (2u * y) * w + 2u * x;
  return (MYRIAD_ENV_SOURCE_RGB(i) + MYRIAD_ENV_SOURCE_RGB(i + 1u) + MYRIAD_ENV_SOURCE_RGB(i + w) +
          MYRIAD_ENV_SOURCE_RGB(i + w + 1u)) * 0.25f;
}

// SH coefficient k of the source, convolved with the cosine lobe (see shBandScale): a Riemann sum
// over the texels of level MYRIAD_ENV_SH_LEVEL, each weighted by its solid angle, in row order.
vec3 projectSH(uint k) {
  uint level = uint(MYRIAD_ENV_SH_LEVEL);
  uint w = uint(MYRIAD_ENV_SOURCE_WIDTH) >> level;
  uint h = uint(MYRIAD_ENV_SOURCE_HEIGHT) >> level;
  uint offset = envSourceOffset(level);
  float texelArea = (2.0f * kPi / float(w)) * (kPi / float(h));
  vec3 sum = vec3(0.0f);
  for (uint y = 0u; y < h; ++y) {
    float v = (float(y) + 0.5f) / float(h);
    float weight = texelArea * sin(v * kPi);
    for (uint x = 0u; x < w; ++x) {
      vec3 d = directionFromEquirect((float(x) + 0.5f) / float(w), v);
      sum += MYRIAD_ENV_SOURCE_RGB(offset + y * w + x) * (shBasis(k, d) * weight);
    }
  }
  return sum * shBandScale(k);
}

// Texel (x, y) of prefiltered level `level` (perceptual roughness level / (levels - 1)): the
// GGX-weighted mean of the source around the texel's direction R, with N = V = R (Karis 2013),
// MYRIAD_ENV_SPECULAR_SAMPLES Hammersley samples, each read from the pyramid level whose texels
// match the sample's solid angle (filtered importance sampling, Krivanek and Colbert 2008).
// Level 0 is the mirror: the source at its 128x64 level.
vec3 prefilterTexel(uint level, uint x, uint y) {
  vec3 N = directionFromEquirect((float(x) + 0.5f) / float(MYRIAD_ENV_SPECULAR_WIDTH),
                                 (float(y) + 0.5f) / float(MYRIAD_ENV_SPECULAR_HEIGHT));
  if (level == 0u) return sampleSource(N, 1.0f);
  float perceptual = float(level) / float(MYRIAD_ENV_SPECULAR_LEVELS - 1);
  float alpha = perceptual * perceptual;
  float alpha2 = alpha * alpha;
  vec3 up = abs(N.z) < 0.999f ? vec3(0.0f, 0.0f, 1.0f) : vec3(1.0f, 0.0f, 0.0f);
  vec3 tx = normalize(cross(up, N));
  vec3 ty = cross(N, tx);
  const uint n = uint(MYRIAD_ENV_SPECULAR_SAMPLES);
  const float texelSolidAngle =
      4.0f * kPi / float(MYRIAD_ENV_SOURCE_WIDTH * MYRIAD_ENV_SOURCE_HEIGHT);
  vec3 sum = vec3(0.0f);
  float weights = 0.0f;
  for (uint i = 0u; i < n; ++i) {
    vec3 t = ggxHalfVector(i, n, alpha);
    vec3 H = tx * t.x + ty * t.y + N * t.z;
    float nDotH = clamp(dot(N, H), 0.0f, 1.0f);
    vec3 L = H * (2.0f * nDotH) - N;
    float nDotL = dot(N, L);
    if (nDotL > 0.0f) {
      float denom = nDotH * nDotH * (alpha2 - 1.0f) + 1.0f;
      float pdf = alpha2 / (kPi * denom * denom) * 0.25f;  // D N.H / (4 V.H), V = N
      float sampleSolidAngle = 1.0f / (float(n) * pdf + 1e-4f);
      float lod = 0.5f * log2(max(sampleSolidAngle / texelSolidAngle, 1e-6f)) + 1.0f;
      sum += sampleSource(normalize(L), lod) * nDotL;
      weights += nDotL;
    }
  }
  return sum * (1.0f / max(weights, 1e-6f));
}
#endif

#ifdef MYRIAD_ENV_LIGHTING
#define MYRIAD_ENV_LIGHTING_RGB(i) vec3(MYRIAD_ENV_LIGHTING(i))

// Outgoing radiance of a white Lambertian surface with normal n (environment space).
vec3 environmentIrradiance(vec3 n) {
  vec3 sum = vec3(0.0f);
  for (uint k = 0u; k < 9u; ++k) sum += MYRIAD_ENV_LIGHTING_RGB(k) * shBasis(k, n);
  return max(sum, vec3(0.0f));
}

// The prefiltered specular along r (environment space) at perceptual roughness `roughness`:
// bilinear in the two levels around roughness * 5, blended.
vec3 environmentSpecular(vec3 r, float roughness) {
  float level = clamp(roughness, 0.0f, 1.0f) * float(MYRIAD_ENV_SPECULAR_LEVELS - 1);
  uint l0 = uint(floor(level));
  uint l1 = min(l0 + 1u, uint(MYRIAD_ENV_SPECULAR_LEVELS - 1));
  const uint size = uint(MYRIAD_ENV_SPECULAR_WIDTH * MYRIAD_ENV_SPECULAR_HEIGHT);
  vec2 uv = equirectFromDirection(r);
  Bilinear b0 = bilinearTaps(uint(MYRIAD_ENV_HEADER) + l0 * size, uint(MYRIAD_ENV_SPECULAR_WIDTH),
                             uint(MYRIAD_ENV_SPECULAR_HEIGHT), uv, true);
  vec3 a = MYRIAD_BILINEAR(MYRIAD_ENV_LIGHTING_RGB, b0);
  if (l1 == l0) return a;
  Bilinear b1 = bilinearTaps(uint(MYRIAD_ENV_HEADER) + l1 * size, uint(MYRIAD_ENV_SPECULAR_WIDTH),
                             uint(MYRIAD_ENV_SPECULAR_HEIGHT), uv, true);
  return mix(a, MYRIAD_BILINEAR(MYRIAD_ENV_LIGHTING_RGB, b1), level - float(l0));
}

// What is seen along a view ray that hits nothing (the background): the mirror level.
vec3 environmentBackground(vec3 d, float c, float s, float intensity) {
  return environmentSpecular(rotateAboutY(d, c, -s), 0.0f) * intensity;
}
#endif

#ifdef MYRIAD_BRDF_LUT
#define MYRIAD_BRDF_LUT_RG(i) vec2(MYRIAD_BRDF_LUT(i))

vec2 brdfLut(float nDotV, float roughness) {
  Bilinear b = bilinearTaps(0u, uint(MYRIAD_BRDF_LUT_SIZE), uint(MYRIAD_BRDF_LUT_SIZE),
                            vec2(clamp(nDotV, 0.0f, 1.0f), clamp(roughness, 0.0f, 1.0f)), false);
  return MYRIAD_BILINEAR(MYRIAD_BRDF_LUT_RG, b);
}
#endif

#if defined(MYRIAD_ENV_LIGHTING) && defined(MYRIAD_BRDF_LUT)
// The environment's light leaving a surface towards V (world space; unit N and V), split-sum
// with Fdez-Aguera's (JCGT 2019) roughness-dependent Fresnel and multiple-scattering terms:
//   kS = F0 + (max(1 - roughness, F0) - F0) (1 - N.V)^5     FssEss = kS A + B   (A, B: the table)
//   Ems = 1 - (A + B)     Favg = F0 + (1 - F0) / 21     FmsEms = Ems FssEss Favg / (1 - Favg Ems)
//   light = prefiltered(R) FssEss + (FmsEms + diffuseColor (1 - FssEss - FmsEms)) irradiance(N)
// so rough metals keep the energy single scattering loses, and diffuse gets what the specular
// lobe leaves. (c, s) rotate world directions into the environment; `intensity` scales it;
// `occlusion` (1 = none) darkens it all, as glTF's occlusion applies to indirect light only.
// shadeEnvironment for a surface given by its diffuse colour and its Fresnel at normal (F0) and
// grazing (F90) incidence: KHR_materials_specular's F90 scales the split sum's second term.
vec3 shadeEnvironmentWith(vec3 N, vec3 V, vec3 diffuseColor, vec3 F0, vec3 F90, float roughness,
                          float occlusion, float c, float s, float intensity) {
  float nDotV = clamp(dot(N, V), 0.0f, 1.0f);
  float rough = clamp(roughness, 0.0f, 1.0f);
  vec3 R = N * (2.0f * dot(N, V)) - V;
  vec3 irradiance = environmentIrradiance(rotateAboutY(N, c, -s));
  vec3 prefiltered = environmentSpecular(rotateAboutY(R, c, -s), rough);
  vec2 ab = brdfLut(nDotV, rough);
  vec3 kS = F0 + (max(vec3(1.0f - rough) * F90, F0) - F0) * pow(1.0f - nDotV, 5.0f);
  vec3 FssEss = kS * ab.x + F90 * ab.y;
  float Ems = clamp(1.0f - (ab.x + ab.y), 0.0f, 1.0f);
  vec3 Favg = F0 + (F90 - F0) * (1.0f / 21.0f);
  vec3 FmsEms = FssEss * Favg * Ems / max(vec3(1.0f) - Favg * Ems, vec3(1e-4f));
  vec3 kD = diffuseColor * max(vec3(1.0f) - FssEss - FmsEms, vec3(0.0f));
  return (prefiltered * FssEss + (FmsEms + kD) * irradiance) * (intensity * occlusion);
}

// The environment light with the layers of b (withLayers) over `base`, the base's term
// (shadeEnvironmentWith), approximated as three.js's MeshPhysicalMaterial does: the sheen adds
// irradiance(N) x colour x E(N.V) (sheenDirectionalAlbedo) over the base scaled by
// 1 - max(sheen) E(N.V); the coat adds clearcoat x its own split sum, prefiltered(R) at its
// roughness times (0.04 A + B) from the table at (N.V, its roughness), over the rest scaled by
// 1 - clearcoat x Fresnel(N.V). Occlusion and intensity scale the layers' terms as the base's.
vec3 environmentThroughLayers(BrdfSurface b, vec3 base, float occlusion, float c, float s,
                              float intensity) {
  if (!MYRIAD_MAY_LAYERS || !b.layered) {
    return base;
  }
  float nDotV = clamp(dot(b.N, b.V), 0.0f, 1.0f);
  vec3 irradiance = environmentIrradiance(rotateAboutY(b.N, c, -s));
  vec3 sheened = base * (1.0f - b.sheenMax * b.sheenAlbedoV) +
                 irradiance * b.sheenColor * (b.sheenAlbedoV * intensity * occlusion);
  vec3 R = b.N * (2.0f * dot(b.N, b.V)) - b.V;
  vec2 ab = brdfLut(nDotV, b.coatRoughness);
  vec3 coat = environmentSpecular(rotateAboutY(R, c, -s), b.coatRoughness) *
              (b.clearcoat * (0.04f * ab.x + ab.y) * intensity * occlusion);
  return sheened * (1.0f - b.coatFresnel) + coat;
}

vec3 shadeEnvironment(vec3 N, vec3 V, vec3 baseColor, float metallic, float roughness,
                      float occlusion, float c, float s, float intensity) {
  return shadeEnvironmentWith(N, V, mix(baseColor, vec3(0.0f), metallic),
                              mix(vec3(0.04f), baseColor, metallic), vec3(1.0f), roughness,
                              occlusion, c, s, intensity);
}
#endif

#endif
