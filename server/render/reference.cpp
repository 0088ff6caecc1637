#include "render/reference.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include <glm/gtc/packing.hpp>

#include "render/light_packing.h"
#include "render/reference_bvh.h"
#include "render/shading.h"
#include "render/shadows.h"
#include "scene/camera.h"

namespace myriad::render {

namespace {

using reference::Bvh;
using reference::Casters;
using reference::RayHit;
using reference::Triangle;

struct Hit {
  float t = std::numeric_limits<float>::max();
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  glm::vec2 uv{0.0f};
  uint32_t material = 0;
  uint32_t object = 0;
  uint32_t semantic = 0;
};

// The first triangle along a pixel's ray (render/reference_bvh.h: the Moller-Trumbore of every
// triangle, through a BVH) and its surface there. Barycentric interpolation in world space equals
// the rasteriser's perspective-correct interpolation at the same pixel centre.
Hit firstHit(const Bvh& bvh, glm::vec3 origin, glm::vec3 dir) {
  Hit best;
  const RayHit ray = bvh.closest(origin, dir);
  if (ray.triangle == RayHit::kNone) return best;
  const Triangle& tri = bvh.triangles()[ray.triangle];
  const float u = ray.u, v = ray.v, w = 1.0f - u - v;
  best.t = ray.t;
  best.position = origin + dir * ray.t;
  glm::vec3 n = w * tri.n[0] + u * tri.n[1] + v * tri.n[2];
  const glm::vec3 geometric = glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
  if (!(glm::dot(n, n) > 1e-12f)) n = geometric;
  n = glm::normalize(n);
  // Both sides are drawn; seen from the back (clockwise on screen) the normal flips, as on the GPU.
  if (glm::dot(geometric, dir) > 0.0f) n = -n;
  best.normal = n;
  best.uv = w * tri.uv[0] + u * tri.uv[1] + v * tri.uv[2];
  best.material = tri.material;
  best.object = tri.object;
  best.semantic = tri.semantic;
  return best;
}

// Calls row(y) for every row on the machine's cores (at most one thread a core, rows handed out
// in turn); each pixel is computed alone, so the image does not depend on the threads. An
// exception a row throws is rethrown after all have run, the lowest row's, as one thread would
// have thrown it first.
template <typename Row>
void forEachRow(uint32_t height, Row row) {
  const uint32_t threads = std::clamp(std::thread::hardware_concurrency(), 1u, std::max(height, 1u));
  std::atomic<uint32_t> next{0};
  std::vector<std::exception_ptr> errors(height);
  auto work = [&] {
    for (uint32_t y; (y = next.fetch_add(1)) < height;) {
      try {
        row(y);
      } catch (...) {
        errors[y] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (uint32_t i = 1; i < threads; ++i) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

float quantizeSnorm16(float x) { return std::round(glm::clamp(x, -1.0f, 1.0f) * 32767.0f) / 32767.0f; }
float quantizeUnorm8(float x) { return std::round(glm::clamp(x, 0.0f, 1.0f) * 255.0f) / 255.0f; }
float half(float x) { return glm::unpackHalf1x16(glm::packHalf1x16(x)); }
glm::vec3 half3(glm::vec3 v) { return {half(v.x), half(v.y), half(v.z)}; }

float srgbDecode(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// What the RGBA8_SRGB base-colour target gives back when sampled.
glm::vec3 storeBaseColor(glm::vec3 c) {
  glm::vec3 out;
  for (int i = 0; i < 3; ++i) out[i] = srgbDecode(quantizeUnorm8(shading::srgbEncode(c[i])));
  return out;
}

glm::vec3 storeNormal(glm::vec3 n) {
  glm::vec2 e = shading::octahedralEncode(n);
  return shading::octahedralDecode(glm::vec2(quantizeSnorm16(e.x), quantizeSnorm16(e.y)));
}

uint8_t toByte(float x) { return static_cast<uint8_t>(std::round(glm::clamp(x, 0.0f, 1.0f) * 255.0f)); }

// The ray through pixel (x, y)'s centre: from the near plane towards the far plane's point.
struct PixelRay {
  glm::vec3 origin;
  glm::vec3 dir;  // unit
  glm::vec3 far;  // the far plane's point
};
PixelRay pixelRay(const glm::mat4& inverseViewProjection, uint32_t x, uint32_t y, uint32_t width,
                  uint32_t height) {
  const glm::vec2 ndc((x + 0.5f) / width * 2.0f - 1.0f, (y + 0.5f) / height * 2.0f - 1.0f);
  const glm::vec4 nearPoint = inverseViewProjection * glm::vec4(ndc, 0.0f, 1.0f);
  const glm::vec4 farPoint = inverseViewProjection * glm::vec4(ndc, 1.0f, 1.0f);
  PixelRay ray;
  ray.origin = glm::vec3(nearPoint) / nearPoint.w;
  ray.far = glm::vec3(farPoint) / farPoint.w;
  ray.dir = glm::normalize(ray.far - ray.origin);
  return ray;
}

}  // namespace


GpuPointLight packLight(const scene::PointLight& l) {
  const bool inverseSquare = l.attenuation == scene::Attenuation::InverseSquare;
  const float attenuation = inverseSquare ? MYRIAD_ATTENUATION_INVERSE_SQUARE : l.falloff;
  glm::vec4 cone(0.0f, 0.0f, MYRIAD_POINT_LIGHT_COS_OUTER, MYRIAD_POINT_LIGHT_COS_INNER);
  if (l.type == scene::LightType::Spot) {
    const glm::vec2 direction = shading::octahedralEncode(glm::normalize(l.direction));
    cone = glm::vec4(direction, float(std::cos(double(l.outerConeAngle))),
                     float(std::cos(double(l.innerConeAngle))));
  }
  return {glm::vec4(l.position, l.radius), glm::vec4(l.color * l.intensity, attenuation), cone};
}

glm::vec3 spotDirectionOf(const GpuPointLight& g) {
  return shading::octahedralDecode(glm::vec2(g.cone.x, g.cone.y));
}

EnvironmentMaps buildEnvironmentMaps(const FrameSettings& s, const scene::EnvironmentImage* image) {
  using namespace shading;
  EnvironmentMaps maps;
  maps.source.assign(MYRIAD_ENV_SOURCE_TEXELS, glm::vec4(0.0f));
  const uint32_t specularSize = MYRIAD_ENV_SPECULAR_WIDTH * MYRIAD_ENV_SPECULAR_HEIGHT;
  maps.lighting.assign(MYRIAD_ENV_HEADER + specularSize * MYRIAD_ENV_SPECULAR_LEVELS, glm::vec4(0.0f));
  maps.lut.assign(MYRIAD_BRDF_LUT_SIZE * MYRIAD_BRDF_LUT_SIZE, glm::vec4(0.0f));
  environmentArrays = {maps.source.data(), maps.lighting.data(), maps.lut.data()};
  for (uint32_t i = 0; i < maps.lut.size(); ++i) {
    maps.lut[i] = glm::vec4(brdfLutTexel(i % MYRIAD_BRDF_LUT_SIZE, i / MYRIAD_BRDF_LUT_SIZE), 0, 0);
  }
  const uint32_t w = MYRIAD_ENV_SOURCE_WIDTH;
  const uint32_t h = MYRIAD_ENV_SOURCE_HEIGHT;
  if (s.environment.mode == EnvironmentMode::Hdr) {
    if (!image || image->rgb.size() != size_t(w) * h * 3) {
      throw std::invalid_argument("reference: the \"hdr\" environment needs its 256x128 image");
    }
    for (uint32_t i = 0; i < w * h; ++i) {
      maps.source[i] = glm::vec4(image->rgb[i * 3], image->rgb[i * 3 + 1], image->rgb[i * 3 + 2], 1.0f);
    }
  } else {
    const glm::vec3 toSun = -glm::normalize(s.sun.direction);
    for (uint32_t i = 0; i < w * h; ++i) maps.source[i] = glm::vec4(skyTexel(i % w, i / w, toSun, s.sun.color), 1.0f);
  }
  for (uint32_t level = 1; level < MYRIAD_ENV_SOURCE_LEVELS; ++level) {
    const uint32_t lw = w >> level;
    const uint32_t offset = envSourceOffset(level);
    for (uint32_t i = 0; i < lw * (h >> level); ++i) {
      maps.source[offset + i] = glm::vec4(downsampleTexel(level, i % lw, i / lw), 1.0f);
    }
  }
  for (uint32_t k = 0; k < 9; ++k) maps.lighting[k] = glm::vec4(projectSH(k), 0.0f);
  for (uint32_t i = 0; i < specularSize * MYRIAD_ENV_SPECULAR_LEVELS; ++i) {
    const uint32_t texel = i % specularSize;
    maps.lighting[MYRIAD_ENV_HEADER + i] =
        glm::vec4(prefilterTexel(i / specularSize, texel % MYRIAD_ENV_SPECULAR_WIDTH,
                                 texel / MYRIAD_ENV_SPECULAR_WIDTH),
                  1.0f);
  }
  environmentArrays = {};
  return maps;
}

std::vector<glm::uvec4> referenceLabels(const scene::Scene& scene, const FrameSettings& s) {
  const Bvh bvh(reference::worldTriangles(scene));
  const float aspect = float(s.width) / float(s.height);
  const glm::mat4 viewProjection =
      scene::projectionMatrix(s.camera, aspect) * scene::viewMatrix(s.camera);
  const glm::mat4 inverse = glm::inverse(viewProjection);
  std::vector<glm::uvec4> labels(size_t(s.width) * s.height, glm::uvec4(0));
  forEachRow(s.height, [&](uint32_t y) {
    for (uint32_t x = 0; x < s.width; ++x) {
      const PixelRay ray = pixelRay(inverse, x, y, s.width, s.height);
      const Hit hit = firstHit(bvh, ray.origin, ray.dir);
      if (hit.t == std::numeric_limits<float>::max()) continue;
      const glm::vec4 clip = viewProjection * glm::vec4(hit.position, 1.0f);
      if (clip.z / clip.w > 1.0f) continue;  // beyond the far plane
      labels[size_t(y) * s.width + x] = glm::uvec4(hit.object, hit.semantic, hit.material, 1u);
    }
  });
  return labels;
}

std::vector<uint8_t> renderReference(const scene::Scene& scene, const FrameSettings& s,
                                     const scene::EnvironmentImage* environmentImage,
                                     std::vector<glm::vec3>* radiance) {
  // The shadow view shows the sun's shadow maps and their cascades, which the reference (exact
  // rays) has not.
  if (s.target == Target::LightVolumes || s.target == Target::LightCount ||
      s.target == Target::Clusters || s.target == Target::Shadow || isLabel(s.target)) {
    throw std::invalid_argument("the reference renderer draws no light-volumes, light-count, "
                                "clusters or shadow-map view");
  }
  const Bvh bvh(reference::worldTriangles(scene));
  const float aspect = float(s.width) / float(s.height);
  const glm::mat4 viewProjection =
      scene::projectionMatrix(s.camera, aspect) * scene::viewMatrix(s.camera);
  const glm::mat4 inverse = glm::inverse(viewProjection);
  const scene::Bounds bounds = scene.bounds();
  const glm::vec3 sunDirection = -glm::normalize(s.sun.direction);
  const bool sunShadows = s.shadows.sun && s.sun.intensity > 0.0f;
  // Shadow rays start this far off the surface, along its normal, so it does not shadow itself.
  const float shadowEpsilon =
      1e-4f * std::max(1.0f, bounds.empty() ? 1.0f : glm::length(bounds.max - bounds.min));
  const float n = s.camera.nearPlane;
  const float f = s.camera.farPlane;
  std::vector<GpuPointLight> lights;
  lights.reserve(scene.lights.size());
  for (const scene::PointLight& l : scene.lights) lights.push_back(packLight(l));
  // The lights the renderer gives a shadow map this frame (the same choice, from the same packed
  // lights): their light is cut by an exact ray to the light instead.
  std::vector<uint8_t> shadowed(lights.size(), 0);
  {
    std::vector<ShadowCaster> casters;
    for (uint32_t i = 0; i < scene.lights.size(); ++i) {
      if (scene.lights[i].castsShadows) casters.push_back({i, lights[i]});
    }
    for (uint32_t index : planLightShadows(casters, s).lights) shadowed[index] = 1;
    // Stochastic shadows converge to every light's exact shadow: a ray per light per pixel.
    if (tracesLocalShadows(s)) std::fill(shadowed.begin(), shadowed.end(), uint8_t(1));
  }
  // Shadow rays are the analytic test, exact where the GPU's shadow maps are filtered (so they
  // differ only in the penumbra band), and where it traces (sun and local lights both) stopped by
  // the triangles its BVH holds.
  const Casters casters = tracesLocalShadows(s) ? Casters::Traced : Casters::All;
  auto occluded = [&](glm::vec3 origin, glm::vec3 dir,
                      float reach = std::numeric_limits<float>::max()) {
    return bvh.occluded(origin, dir, reach, casters);
  };
  const bool environmentOn = s.environment.mode != EnvironmentMode::None;
  EnvironmentMaps maps;
  if (environmentOn) maps = buildEnvironmentMaps(s, environmentImage);
  // As render/renderer.cpp writes them into the frame uniforms.
  const float rotation = s.environment.mode == EnvironmentMode::Hdr ? s.environment.rotation : 0.0f;
  const float rotationCos = std::cos(rotation);
  const float rotationSin = std::sin(rotation);

  std::vector<uint8_t> image(size_t(s.width) * s.height * 4);
  if (radiance) radiance->assign(size_t(s.width) * s.height, glm::vec3(0.0f));
  forEachRow(s.height, [&](uint32_t y) {
    // Per thread (shading.h): the maps the environment's functions read.
    shading::environmentArrays = {maps.source.data(), maps.lighting.data(), maps.lut.data()};
    for (uint32_t x = 0; x < s.width; ++x) {
      const PixelRay ray = pixelRay(inverse, x, y, s.width, s.height);
      const glm::vec3 origin = ray.origin;
      const glm::vec3 dir = ray.dir;
      const Hit hit = firstHit(bvh, origin, dir);
      bool found = hit.t < std::numeric_limits<float>::max();
      float depth = 1.0f;
      if (found) {
        glm::vec4 clip = viewProjection * glm::vec4(hit.position, 1.0f);
        depth = clip.z / clip.w;
        if (depth > 1.0f) found = false;  // beyond the far plane: clipped on the GPU too
      }

      glm::vec3 color(0.0f);
      const scene::Material material = found ? scene.materials.at(hit.material) : scene::Material{};
      const glm::vec3 normal = storeNormal(hit.normal);
      const glm::vec3 baseColor = storeBaseColor(material.baseColor);
      const float metallic = quantizeUnorm8(material.metallic);
      const float roughness = quantizeUnorm8(material.roughness);
      // Textures are not sampled here (the reference is for the shading and the culling): a
      // material's own factors, with occlusion 1 as for a material without an occlusion map.
      // An unlit material (KHR_materials_unlit) emits its base colour and reflects nothing
      // (material_core.glsl's withUnlit).
      const glm::vec3 emissive = material.unlit ? half3(material.baseColor)
                                                : half3(material.emissive * material.emissiveStrength);
      const float reflectance = material.unlit ? 0.0f : 1.0f;
      // The dielectric's Fresnel at normal and grazing incidence (KHR_materials_ior, _specular),
      // as frame.glsl's brdfSurfaceOf applies them.
      const float iorRatio = (material.ior - 1.0f) / (material.ior + 1.0f);
      const float dielectricF0 = std::min(iorRatio * iorRatio, 1.0f) * material.specular;
      const float specular = quantizeUnorm8(material.specular);
      // KHR_materials_clearcoat and _sheen, 8 bits each as the layers target holds them.
      const bool layered = material.layered();
      const float clearcoat = quantizeUnorm8(material.clearcoat);
      const float clearcoatRoughness = quantizeUnorm8(material.clearcoatRoughness);
      const glm::vec3 sheenColor(quantizeUnorm8(material.sheenColor.r),
                                 quantizeUnorm8(material.sheenColor.g),
                                 quantizeUnorm8(material.sheenColor.b));
      const float sheenRoughness = quantizeUnorm8(material.sheenRoughness);
      switch (s.target) {
        case Target::Final: {
          glm::vec3 hdr = half3(s.background);
          if (!found && environmentOn && s.environment.background) {
            glm::vec3 d = glm::normalize(ray.far - s.camera.eye);
            hdr = half3(shading::environmentBackground(d, rotationCos, rotationSin,
                                                       s.environment.intensity));
          }
          if (found) {
            glm::vec3 V = glm::normalize(s.camera.eye - hit.position);
            glm::vec3 sunRadiance = s.sun.color * s.sun.intensity;
            if (sunShadows && glm::dot(hit.normal, sunDirection) > 0.0f &&
                occluded(hit.position + hit.normal * shadowEpsilon, sunDirection)) {
              sunRadiance = glm::vec3(0.0f);
            }
            shading::BrdfSurface b = shading::brdfSurface(normal, V, baseColor, metallic, roughness);
            b.F0 = glm::mix(glm::vec3(dielectricF0), baseColor, metallic) * reflectance;
            b.oneMinusF0 = glm::mix(glm::vec3(specular), glm::vec3(1.0f), metallic) * reflectance - b.F0;
            b.diffuseColor *= reflectance;
            b.diffuseOverPi *= reflectance;
            // A material without layers shades the same with them (withLayers says why), so
            // only layered ones take them, wherever the scene's others are.
            if (layered) {
              b = shading::withLayers(b, clearcoat, clearcoatRoughness, sheenColor, sheenRoughness);
            }
            glm::vec3 sunAndAmbient = shading::brdfCosineAt(b, sunDirection) * sunRadiance;
            if (!environmentOn) {
              sunAndAmbient += shading::ambientThroughLayers(b, s.ambient * (b.diffuseColor + b.F0),
                                                             s.ambient);
            } else {
              const glm::vec3 base = shading::shadeEnvironmentWith(
                  normal, V, b.diffuseColor, b.F0, b.F0 + b.oneMinusF0, roughness, 1.0f,
                  rotationCos, rotationSin, s.environment.intensity);
              sunAndAmbient += shading::environmentThroughLayers(b, base, 1.0f, rotationCos,
                                                                 rotationSin,
                                                                 s.environment.intensity);
            }
            for (const scene::Sun& extra : s.extraSuns) {
              if (extra.intensity > 0.0f) {
                sunAndAmbient += shading::brdfCosineAt(b, -glm::normalize(extra.direction)) *
                                 (extra.color * extra.intensity);
              }
            }
            // Emission is added with the sun and ambient (or environment) term, as on the GPU,
            // under the coat.
            hdr = half3(sunAndAmbient + shading::throughLayers(b, emissive));
            for (size_t i = 0; i < lights.size(); ++i) {
              const GpuPointLight& l = lights[i];
              glm::vec3 c = shading::shadeLocalLightAt(
                  b, hit.position, glm::vec3(l.positionRadius), l.positionRadius.w,
                  glm::vec3(l.radianceFalloff), l.radianceFalloff.w, spotDirectionOf(l), l.cone.z,
                  l.cone.w);
              if (shadowed[i] && c != glm::vec3(0.0f)) {
                const glm::vec3 toLight = glm::vec3(l.positionRadius) - hit.position;
                const float distance = glm::length(toLight);
                if (glm::dot(hit.normal, toLight) > 0.0f &&
                    occluded(hit.position + hit.normal * shadowEpsilon, toLight / distance,
                             distance)) {
                  c = glm::vec3(0.0f);
                }
              }
              if (c != glm::vec3(0.0f)) hdr = half3(hdr + half3(c));
            }
          }
          // The GPU keeps NaN and Inf in its HDR target; a reference that clamped them to a byte
          // would agree with a broken image. Refuse instead.
          if (glm::any(glm::isnan(hdr)) || glm::any(glm::isinf(hdr))) {
            throw std::domain_error("reference: non-finite radiance at pixel (" +
                                    std::to_string(x) + ", " + std::to_string(y) + ")");
          }
          if (radiance) (*radiance)[size_t(y) * s.width + x] = hdr;
          color = shading::srgbEncode3(shading::tonemapPbrNeutral(hdr * s.exposure));
          break;
        }
        case Target::Albedo: color = found ? shading::srgbEncode3(baseColor) : glm::vec3(0.0f); break;
        case Target::Normal: color = found ? normal * 0.5f + 0.5f : glm::vec3(0.0f); break;
        case Target::Position: {
          glm::vec3 extent = glm::max(bounds.max - bounds.min, glm::vec3(1e-6f));
          color = found ? glm::clamp((hit.position - bounds.min) / extent, 0.0f, 1.0f) : glm::vec3(0.0f);
          break;
        }
        case Target::Uv: color = found ? glm::vec3(glm::fract(hit.uv), 0.0f) : glm::vec3(0.0f); break;
        case Target::Metallic: color = glm::vec3(found ? metallic : 0.0f); break;
        case Target::Roughness: color = glm::vec3(found ? roughness : 0.0f); break;
        case Target::Depth: {
          float linear = n * f / (f - depth * (f - n));
          color = glm::vec3(found ? glm::clamp((linear - n) / (f - n), 0.0f, 1.0f) : 1.0f);
          break;
        }
        case Target::Emissive:
          color = found ? shading::srgbEncode3(shading::tonemapPbrNeutral(emissive * s.exposure))
                        : glm::vec3(0.0f);
          break;
        case Target::Occlusion: color = glm::vec3(found ? 1.0f : 0.0f); break;
        case Target::InstanceId:
        case Target::SemanticId:
        case Target::MaterialId:  // referenceLabels
        case Target::Motion:
        case Target::LightVolumes:
        case Target::LightCount:
        case Target::Clusters:
        case Target::Shadow: break;
      }
      uint8_t* px = &image[(size_t(y) * s.width + x) * 4];
      px[0] = toByte(color.r);
      px[1] = toByte(color.g);
      px[2] = toByte(color.b);
      px[3] = 255;
    }
    shading::environmentArrays = {};
  });
  return image;
}

}  // namespace myriad::render
