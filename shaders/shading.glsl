// Myriad's shading model, written once in the common subset of GLSL 4.50 and C++20/GLM.
//
// The shaders #include this file; server/render/shading.h includes it inside a C++ namespace with
// `using namespace glm`, and that copy is the reference the tests judge GPU images with. Rules for
// editing: no swizzles, no in/out/inout parameters, float literals with an f suffix, and only
// functions GLM also provides (dot, max, min, clamp, mix, sqrt, inversesqrt, pow, exp, abs,
// normalize). Keep every argument inside its function's domain (pow's base >= 0, sqrt's >= 0,
// inversesqrt's > 0, normalize's non-zero): GLSL leaves the rest undefined, and the C++ twin's pow
// gives NaN there so tests catch it.

#ifndef MYRIAD_SHADING_GLSL
#define MYRIAD_SHADING_GLSL

const float kPi = 3.14159265358979f;

// Perceptual roughness below this makes GGX a near-delta that 16-bit targets cannot hold.
const float kMinRoughness = 0.045f;

// Which kinds of local light the caller may pass (frame.glsl narrows them per frame with a
// specialisation constant, so a frame with none of a kind has its code compiled out); the C++
// reference and every unspecialised shader take each kind.
#ifndef MYRIAD_MAY_SPOT
#define MYRIAD_MAY_SPOT true
#endif
#ifndef MYRIAD_MAY_WINDOW_FALLOFF
#define MYRIAD_MAY_WINDOW_FALLOFF true
#endif
#ifndef MYRIAD_MAY_INVERSE_SQUARE
#define MYRIAD_MAY_INVERSE_SQUARE true
#endif
// Whether a surface may have a clear coat or a sheen (withLayers); false compiles the layers out.
#ifndef MYRIAD_MAY_LAYERS
#define MYRIAD_MAY_LAYERS true
#endif

// The seed's windowed falloff: exactly 0 at and beyond the radius, 1 at the light.
// C (>= 0) shapes the curve: 0 gives the quadratic window 1 - d^2/r^2, larger C falls off faster.
float distanceAttenuation(float d, float radius, float C) {
  float r2 = radius * radius;
  float d2 = d * d;
  return clamp((r2 - d2) / (C * d2 + r2), 0.0f, 1.0f);
}

// A surface closer to an inverse-square light than sqrt(this) gets the radiance it would get at that
// distance instead of a division by zero (three.js bounds d^2 the same way; glTF leaves it open).
const float kMinLightDistance2 = 0.01f;

// glTF KHR_lights_punctual's recommended falloff: the inverse-square law, 1/d^2, times a smooth
// window reaching exactly 0 at `range`: clamp(1 - (d/range)^4, 0, 1)^2 (as three.js and Filament).
// With intensity in candela, intensity * this is the illuminance (lux) at distance d.
float inverseSquareAttenuation(float d, float range) {
  float ratio = d / range;
  float ratio2 = ratio * ratio;
  float window = clamp(1.0f - ratio2 * ratio2, 0.0f, 1.0f);
  return window * window / max(d * d, kMinLightDistance2);
}

// A light's falloff as GpuPointLight stores it: C >= 0 the window with that constant, C < 0
// (MYRIAD_ATTENUATION_INVERSE_SQUARE) inverse-square.
float lightAttenuation(float d, float radius, float C) {
  if (!MYRIAD_MAY_INVERSE_SQUARE) {
    return distanceAttenuation(d, radius, C);
  }
  if (!MYRIAD_MAY_WINDOW_FALLOFF) {
    return inverseSquareAttenuation(d, radius);
  }
  return C < 0.0f ? inverseSquareAttenuation(d, radius) : distanceAttenuation(d, radius, C);
}

// The same from the squared distance d2 and squared radius r2, for the light loops (no square
// root needed for the window; the inverse-square law takes d from d2).
float lightAttenuationSquared(float d2, float r2, float C) {
  bool inverseSquare = MYRIAD_MAY_INVERSE_SQUARE && (!MYRIAD_MAY_WINDOW_FALLOFF || C < 0.0f);
  if (inverseSquare) {
    float ratio2 = d2 / r2;
    float window = clamp(1.0f - ratio2 * ratio2, 0.0f, 1.0f);
    return window * window / max(d2, kMinLightDistance2);
  }
  return clamp((r2 - d2) / (C * d2 + r2), 0.0f, 1.0f);
}

// Cosine of the angle between a spot light's direction and the way from the light to the point,
// given toLight = light position - point and d = its length; 1 (on the axis) at the light itself.
float spotCosine(vec3 toLight, float d, vec3 spotDirection) {
  return d > 1e-6f ? -dot(spotDirection, toLight) / d : 1.0f;
}

// glTF KHR_lights_punctual's recommended spot falloff: linear in the cosine from 0 at the outer
// cone to 1 at the inner one (the spread at least 0.001, as the spec's sample code), squared. It is
// exactly 0 for cosAngle <= cosOuter. A point light passes cosOuter = -2, cosInner = -1: always 1.
float spotAttenuation(float cosAngle, float cosOuter, float cosInner) {
  float t = clamp((cosAngle - cosOuter) / max(cosInner - cosOuter, 0.001f), 0.0f, 1.0f);
  return t * t;
}

// Whether a local light reaches P at all: closer than its radius and inside its outer cone (what
// the light-count view counts; shadeLocalLight is exactly 0 wherever this is false).
bool localLightReaches(vec3 P, vec3 lightPosition, float radius, vec3 spotDirection,
                       float cosOuter) {
  vec3 toLight = lightPosition - P;
  float d2 = dot(toLight, toLight);
  if (d2 >= radius * radius) {
    return false;
  }
  if (!MYRIAD_MAY_SPOT) {
    return true;  // a point light's cone (cosOuter -2) holds every direction
  }
  return spotCosine(toLight, sqrt(d2), spotDirection) > cosOuter;
}

// What brdfCosine needs of a surface point and the view alone, worked out once for a loop over
// many lights at one point (brdfSurface; brdfCosineAt then takes each light's direction).
struct BrdfSurface {
  vec3 N;              // unit normal
  vec3 V;              // unit vector towards the eye
  float NdotV;         // |N.V| + 1e-5
  float NdotVSigned;   // N.V
  float alpha2;        // GGX alpha squared (alpha = clamped perceptual roughness squared)
  float visV;          // the view's half of the Smith visibility denominator
  vec3 F0;             // Fresnel at normal incidence
  vec3 oneMinusF0;     // 1 - F0
  vec3 diffuseColor;   // base colour without the metal's part
  vec3 diffuseOverPi;  // diffuseColor / pi: the Lambert term
  float specularScale; // alpha2 / (pi visV): D Vis = specularScale / (denom^2 visL)
  // The layers on top of the base (withLayers; brdfSurface leaves none): KHR_materials_sheen,
  // then KHR_materials_clearcoat over both.
  bool layered;           // false: the base BRDF alone, whatever the members below hold
  float clearcoat;        // the coat's factor, [0, 1]
  float coatRoughness;    // the coat's perceptual roughness (clamped as the base's)
  float coatAlpha2;       // its GGX alpha squared
  float coatScale;        // coatAlpha2 / (pi coatVisV), as specularScale
  float coatFresnel;      // clearcoat x the coat's Fresnel at N.V: what the coat reflects, and
                          // the share of the light the layers below lose to it
  vec3 sheenColor;
  float sheenRoughness;   // clamped to [kMinRoughness, 1]: the Charlie peak, (2 + 1/alpha) / 2pi,
                          // would pass half floats' range near 0 (three.js goes down to 1e-4)
  float sheenInverseAlpha;  // 1 / sheenRoughness^2
  float sheenMax;         // the largest channel of sheenColor
  float sheenAlbedoV;     // the sheen's directional albedo towards the eye, E(N.V)
};

BrdfSurface brdfSurface(vec3 N, vec3 V, vec3 baseColor, float metallic, float roughness) {
  BrdfSurface b;
  b.N = N;
  b.V = V;
  b.NdotVSigned = dot(N, V);
  b.NdotV = abs(b.NdotVSigned) + 1e-5f;
  float perceptual = clamp(roughness, kMinRoughness, 1.0f);
  float alpha = perceptual * perceptual;
  b.alpha2 = alpha * alpha;
  b.visV = b.NdotV + sqrt(b.alpha2 + (1.0f - b.alpha2) * b.NdotV * b.NdotV);
  b.F0 = mix(vec3(0.04f), baseColor, metallic);
  b.oneMinusF0 = vec3(1.0f) - b.F0;
  b.diffuseColor = mix(baseColor, vec3(0.0f), metallic);
  b.diffuseOverPi = b.diffuseColor * (1.0f / kPi);
  b.specularScale = b.alpha2 / (kPi * b.visV);
  b.layered = false;
  b.clearcoat = 0.0f;
  b.coatRoughness = 0.0f;
  b.coatAlpha2 = 0.0f;
  b.coatScale = 0.0f;
  b.coatFresnel = 0.0f;
  b.sheenColor = vec3(0.0f);
  b.sheenRoughness = 1.0f;
  b.sheenInverseAlpha = 1.0f;
  b.sheenMax = 0.0f;
  b.sheenAlbedoV = 0.0f;
  return b;
}

// The directional albedo E(cos) of the sheen BRDF (KHR_materials_sheen's albedo scaling: the
// share of light the sheen takes from the layers below it): an exponential curve fitted to the
// Charlie sheen with Neubelt visibility, E = exp(a cos + b) with a and b quadratic in the
// roughness r plus a 1/(r + 0.1) term. The fit is the one three.js uses (its IBLSheenBRDF), so
// the two renderers take the same light from the base; the spec leaves E to a table or a fit.
float sheenDirectionalAlbedo(float cosine, float roughness) {
  float r = roughness;
  float r2 = r * r;
  float inverse = 1.0f / (r + 0.1f);
  float a = -1.9362f + 1.0678f * r + 0.4573f * r2 - 0.8469f * inverse;
  float b = -0.6014f + 0.5538f * r - 0.4670f * r2 - 0.1255f * inverse;
  return clamp(exp(a * clamp(cosine, 0.0f, 1.0f) + b), 0.0f, 1.0f);
}

// Schlick's Fresnel of the clear coat (ior 1.5: F0 0.04, F90 1) at cosine c.
float coatFresnelAt(float c) {
  float m = 1.0f - clamp(c, 0.0f, 1.0f);
  float m2 = m * m;
  return 0.04f + 0.96f * (m2 * m2 * m);
}

// The surface b with a clear coat (KHR_materials_clearcoat: factor, perceptual roughness; F0 0.04,
// the base's normal) and a sheen (KHR_materials_sheen: colour, roughness) on top of it. With a
// factor of 0 and a black sheen brdfCosineAt returns the base's value exactly.
BrdfSurface withLayers(BrdfSurface b, float clearcoat, float coatRoughness, vec3 sheenColor,
                       float sheenRoughness) {
  b.layered = true;
  float perceptual = clamp(coatRoughness, kMinRoughness, 1.0f);
  b.coatRoughness = perceptual;
  float alpha = perceptual * perceptual;
  b.coatAlpha2 = alpha * alpha;
  float coatVisV = b.NdotV + sqrt(b.coatAlpha2 + (1.0f - b.coatAlpha2) * b.NdotV * b.NdotV);
  b.coatScale = b.coatAlpha2 / (kPi * coatVisV);
  // The extension's clearcoat_fresnel, from N.V rather than V.H: one factor for the whole pixel,
  // which also scales what the base reflects of the environment and what it emits.
  b.clearcoat = clamp(clearcoat, 0.0f, 1.0f);
  b.coatFresnel = b.clearcoat * coatFresnelAt(b.NdotV);
  b.sheenColor = sheenColor;
  b.sheenRoughness = clamp(sheenRoughness, kMinRoughness, 1.0f);
  b.sheenInverseAlpha = 1.0f / (b.sheenRoughness * b.sheenRoughness);
  b.sheenMax = max(sheenColor.x, max(sheenColor.y, sheenColor.z));
  b.sheenAlbedoV = sheenDirectionalAlbedo(b.NdotV, b.sheenRoughness);
  return b;
}

// The layers over `base` (the base BRDF times N.L) for light from L: the sheen (Charlie
// distribution, Estevez and Kulla 2017, with the Neubelt visibility 1 / (4 (N.L + N.V - N.L N.V)),
// which KHR_materials_sheen offers as its cheaper "Ashikhmin" visibility) added on top of the base
// scaled by the albedo scaling min(1 - max(sheen) E(N.V), 1 - max(sheen) E(N.L)); then the coat,
// a GGX lobe of its own roughness with the base's visibility, weighted by clearcoat x Fresnel(N.V),
// over the rest scaled by 1 - that.
vec3 layersCosineAt(BrdfSurface b, vec3 base, float NdotL, float NdotH) {
  float sin2 = max(1.0f - NdotH * NdotH, 0.0078125f);
  float sheenD =
      (2.0f + b.sheenInverseAlpha) * pow(sin2, 0.5f * b.sheenInverseAlpha) * (0.5f / kPi);
  float sheenVis = clamp(1.0f / (4.0f * (NdotL + b.NdotV - NdotL * b.NdotV)), 0.0f, 1.0f);
  float sheenScaling =
      1.0f - b.sheenMax * max(b.sheenAlbedoV, sheenDirectionalAlbedo(NdotL, b.sheenRoughness));
  vec3 sheened = base * sheenScaling + b.sheenColor * (sheenD * sheenVis * NdotL);
  float denom = NdotH * NdotH * (b.coatAlpha2 - 1.0f) + 1.0f;
  float visL = NdotL + sqrt(b.coatAlpha2 + (1.0f - b.coatAlpha2) * NdotL * NdotL);
  float coatDVis = b.coatScale / (denom * denom * visL);
  return sheened * (1.0f - b.coatFresnel) + vec3(b.coatFresnel * coatDVis * NdotL);
}

// What the layers let through of light leaving the base under them (its emission): the coat's
// 1 - clearcoat x Fresnel (the sheen, as in three.js, does not dim emission).
vec3 throughLayers(BrdfSurface b, vec3 light) {
  if (!MYRIAD_MAY_LAYERS || !b.layered) {
    return light;
  }
  return light * (1.0f - b.coatFresnel);
}

// The constant ambient term (shadeSunAndAmbient's rough split sum) with the layers: `base` is the
// base's term for radiance `ambient`; the sheen adds ambient x colour x E(N.V) over the base
// scaled by 1 - max(sheen) E(N.V); the coat reflects ambient x clearcoat x Fresnel(N.V), what the
// rest loses.
vec3 ambientThroughLayers(BrdfSurface b, vec3 base, vec3 ambient) {
  if (!MYRIAD_MAY_LAYERS || !b.layered) {
    return base;
  }
  vec3 sheened =
      base * (1.0f - b.sheenMax * b.sheenAlbedoV) + ambient * b.sheenColor * b.sheenAlbedoV;
  return sheened * (1.0f - b.coatFresnel) + ambient * b.coatFresnel;
}

// glTF 2.0 metallic-roughness BRDF (specification, Appendix B), times the cosine term:
// returns f(l, v) * max(N.L, 0) for the surface b and the unit vector L towards the light.
// Written for the light loops' instruction count (every lighting pass runs it per pixel-light
// pair): the half vector's cosines come from N.V, N.L and V.L (|V + L|^2 = 2 + 2 V.L for unit
// vectors) without forming H, the Fresnel power by multiplication, and D and Vis share one
// division: f = (1 - F) diffuse / pi + F D Vis = diffuse / pi + F (D Vis - diffuse / pi).
// A surface with layers (withLayers) has them added over that (layersCosineAt).
vec3 brdfCosineAt(BrdfSurface b, vec3 L) {
  float NdotL = dot(b.N, L);
  if (NdotL <= 0.0f) {
    return vec3(0.0f);
  }
  // With L along V (a light at the eye or on the view ray) V.H rounds to just over 1; cosines
  // are clamped to [0, 1]. V + L is zero only for a light exactly behind a grazing view; N
  // stands in for H there.
  float VdotL = dot(b.V, L);
  float halfwayLength2 = 2.0f + 2.0f * VdotL;
  float NdotH = 1.0f;
  float VdotH = clamp(b.NdotVSigned, 0.0f, 1.0f);
  if (halfwayLength2 > 1e-12f) {
    float inverseLength = inversesqrt(halfwayLength2);
    NdotH = clamp((b.NdotVSigned + NdotL) * inverseLength, 0.0f, 1.0f);
    VdotH = clamp(0.5f * halfwayLength2 * inverseLength, 0.0f, 1.0f);
  }
  float alpha2 = b.alpha2;

  // Schlick Fresnel with F0 = mix(0.04, baseColor, metallic).
  float m = 1.0f - VdotH;
  float m2 = m * m;
  float fresnelWeight = m2 * m2 * m;
  vec3 F = b.F0 + b.oneMinusF0 * fresnelWeight;

  // Trowbridge-Reitz (GGX) distribution D = alpha2 / (pi denom^2) times the Smith joint visibility
  // Vis = G / (4 N.L N.V) = 1 / (visL visV), as in the glTF spec.
  float denom = NdotH * NdotH * (alpha2 - 1.0f) + 1.0f;
  float visL = NdotL + sqrt(alpha2 + (1.0f - alpha2) * NdotL * NdotL);
  float DVis = b.specularScale / (denom * denom * visL);

  vec3 base = (b.diffuseOverPi + F * (vec3(DVis) - b.diffuseOverPi)) * NdotL;
  if (MYRIAD_MAY_LAYERS && b.layered) {
    return layersCosineAt(b, base, NdotL, NdotH);
  }
  return base;
}

// The same for one light: N, V, L are unit vectors; V and L point away from the surface.
vec3 brdfCosine(vec3 N, vec3 V, vec3 L, vec3 baseColor, float metallic, float roughness) {
  return brdfCosineAt(brdfSurface(N, V, baseColor, metallic, roughness), L);
}

// Outgoing radiance from a local light (point or spot) at lightPosition reaching surface point P:
// BRDF * cos * radiance * distance falloff (C as lightAttenuation) * cone falloff. Exactly 0 at and
// beyond the radius and outside the outer cone. For the surface b (brdfSurface) at P:
vec3 shadeLocalLightAt(BrdfSurface b, vec3 P, vec3 lightPosition, float radius, vec3 radiance,
                       float C, vec3 spotDirection, float cosOuter, float cosInner) {
  vec3 toLight = lightPosition - P;
  float d2 = dot(toLight, toLight);
  float r2 = radius * radius;
  if (d2 >= r2) {
    return vec3(0.0f);
  }
  // One reciprocal square root gives L and, for a spot, its cosine (d > 1e-6 as spotCosine).
  float inverseD = inversesqrt(max(d2, 1e-30f));
  bool apart = d2 > 1e-12f;
  vec3 L = apart ? toLight * inverseD : b.N;
  float falloff = lightAttenuationSquared(d2, r2, C);
  if (MYRIAD_MAY_SPOT) {  // without: a point light's cone factor, 1 (cosOuter -2, cosInner -1)
    float cosAngle = apart ? -dot(spotDirection, toLight) * inverseD : 1.0f;
    if (cosAngle <= cosOuter) {
      return vec3(0.0f);
    }
    falloff *= spotAttenuation(cosAngle, cosOuter, cosInner);
  }
  return brdfCosineAt(b, L) * (radiance * falloff);
}

// The same from the surface's normal, view vector and material.
vec3 shadeLocalLight(vec3 P, vec3 N, vec3 V, vec3 baseColor, float metallic, float roughness,
                     vec3 lightPosition, float radius, vec3 radiance, float C, vec3 spotDirection,
                     float cosOuter, float cosInner) {
  return shadeLocalLightAt(brdfSurface(N, V, baseColor, metallic, roughness), P, lightPosition,
                           radius, radiance, C, spotDirection, cosOuter, cosInner);
}

// A point light with the window falloff (C >= 0).
vec3 shadePointLight(vec3 P, vec3 N, vec3 V, vec3 baseColor, float metallic, float roughness,
                     vec3 lightPosition, float radius, vec3 radiance, float C) {
  return shadeLocalLight(P, N, V, baseColor, metallic, roughness, lightPosition, radius, radiance,
                         C, N, -2.0f, -1.0f);
}

// Sun (directional, towards-the-sun unit vector) plus a uniform ambient environment. The ambient
// term is the BRDF's hemispherical integral under constant radiance, approximated as the diffuse
// colour plus F0 (a rough split-sum): metals reflect their base colour, dielectrics ~4% more.
vec3 shadeSunAndAmbient(vec3 N, vec3 V, vec3 baseColor, float metallic, float roughness,
                        vec3 sunDirection, vec3 sunRadiance, vec3 ambient) {
  vec3 diffuseColor = mix(baseColor, vec3(0.0f), metallic);
  vec3 F0 = mix(vec3(0.04f), baseColor, metallic);
  vec3 ambientTerm = ambient * (diffuseColor + F0);
  return brdfCosine(N, V, sunDirection, baseColor, metallic, roughness) * sunRadiance +
         ambientTerm;
}

// Khronos PBR Neutral tone mapping (Khronos 3D Commerce, 2024): hue-preserving, identity below
// 0.76, smooth compression of highlights towards white above it. Input: exposed linear colour.
vec3 tonemapPbrNeutral(vec3 color) {
  const float startCompression = 0.8f - 0.04f;
  const float desaturation = 0.15f;
  float x = min(color.x, min(color.y, color.z));
  float offset = x < 0.08f ? x - 6.25f * x * x : 0.04f;
  color = color - vec3(offset);
  float peak = max(color.x, max(color.y, color.z));
  if (peak < startCompression) {
    return color;
  }
  const float d = 1.0f - startCompression;
  float newPeak = 1.0f - d * d / (peak + d - startCompression);
  color = color * (newPeak / peak);
  float g = 1.0f - 1.0f / (desaturation * (peak - newPeak) + 1.0f);
  return mix(color, vec3(newPeak), g);
}

// Linear -> sRGB transfer (IEC 61966-2-1), per channel, input clamped to [0, 1].
float srgbEncode(float linear) {
  float c = clamp(linear, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * pow(c, 1.0f / 2.4f) - 0.055f;
}

vec3 srgbEncode3(vec3 linear) {
  return vec3(srgbEncode(linear.x), srgbEncode(linear.y), srgbEncode(linear.z));
}

// Octahedral normal encoding (Cigolle et al., JCGT 2014) into [-1, 1]^2, stored as RG16_SNORM.
float signNotZero(float v) { return v >= 0.0f ? 1.0f : -1.0f; }

vec2 octahedralEncode(vec3 n) {
  float l1 = abs(n.x) + abs(n.y) + abs(n.z);
  vec2 p = vec2(n.x, n.y) * (1.0f / l1);
  if (n.z < 0.0f) {
    p = vec2((1.0f - abs(p.y)) * signNotZero(p.x), (1.0f - abs(p.x)) * signNotZero(p.y));
  }
  return p;
}

vec3 octahedralDecode(vec2 e) {
  vec3 n = vec3(e.x, e.y, 1.0f - abs(e.x) - abs(e.y));
  if (n.z < 0.0f) {
    n = vec3((1.0f - abs(e.y)) * signNotZero(e.x), (1.0f - abs(e.x)) * signNotZero(e.y), n.z);
  }
  return normalize(n);
}

#endif
