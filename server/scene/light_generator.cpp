#include "scene/light_generator.h"

#include <algorithm>
#include <cmath>

namespace myriad::scene {

namespace {

constexpr uint64_t kPcgMultiplier = 6364136223846793005ull;

// Which of PCG's 2^63 streams the lights draw from; any constant works, the seed picks the place.
constexpr uint64_t kLightStream = 0x4d79726961644c74ull;  // "MyriadLt"

glm::vec3 hsvToRgb(float hue, float saturation, float value) {
  const float h = (hue - std::floor(hue)) * 6.0f;
  const auto sector = std::min(int(h), 5);
  const float f = h - float(sector);
  const float p = value * (1.0f - saturation);
  const float q = value * (1.0f - saturation * f);
  const float t = value * (1.0f - saturation * (1.0f - f));
  switch (sector) {
    case 0:
      return {value, t, p};
    case 1:
      return {q, value, p};
    case 2:
      return {p, value, t};
    case 3:
      return {p, q, value};
    case 4:
      return {t, p, value};
    default:
      return {value, p, q};
  }
}

}  // namespace

Pcg32::Pcg32(uint64_t seed, uint64_t stream) : increment_((stream << 1u) | 1u) {
  // The reference seeding: step once from zero, add the seed, step again, so that nearby seeds do
  // not start in nearby states.
  next();
  state_ += seed;
  next();
}

uint32_t Pcg32::next() {
  const uint64_t previous = state_;
  state_ = previous * kPcgMultiplier + increment_;
  // Output from the old state, so the multiply above overlaps with this on out-of-order CPUs.
  const auto xorshifted = uint32_t(((previous >> 18u) ^ previous) >> 27u);
  const auto rotation = uint32_t(previous >> 59u);
  return (xorshifted >> rotation) | (xorshifted << ((32u - rotation) & 31u));
}

// The top 24 bits fill a float's mantissa exactly, so no rounding can reach 1.
float Pcg32::unit() {
  return float(next() >> 8u) * (1.0f / 16777216.0f);
}

// Computed in double and rounded once, so that a fused multiply-add on one platform and not on
// another cannot change the float result except in the rarest ties.
float Pcg32::uniform(float low, float high) {
  return float(double(low) + (double(high) - double(low)) * double(unit()));
}

std::vector<PointLight> generateLights(const LightGeneration& params) {
  // Empty bounds (the default) have min > max; collapse them to the origin rather than scattering
  // lights at +-FLT_MAX.
  const glm::vec3 low = params.bounds.empty() ? glm::vec3(0.0f) : params.bounds.min;
  const glm::vec3 high = params.bounds.empty() ? glm::vec3(0.0f) : params.bounds.max;
  const float saturation = std::clamp(params.saturation, 0.0f, 1.0f);

  Pcg32 random(params.seed, kLightStream);
  std::vector<PointLight> lights;
  lights.reserve(params.count);
  for (uint32_t i = 0; i < params.count; ++i) {
    // One fixed order of draws per light: reordering these changes every existing layout.
    PointLight light;
    light.position.x = random.uniform(low.x, high.x);
    light.position.y = random.uniform(low.y, high.y);
    light.position.z = random.uniform(low.z, high.z);
    light.radius = random.uniform(params.minRadius, params.maxRadius);
    light.intensity = random.uniform(params.minIntensity, params.maxIntensity);
    light.color = hsvToRgb(random.unit(), saturation, 1.0f);
    light.falloff = params.falloff;
    lights.push_back(light);
  }
  return lights;
}

}  // namespace myriad::scene
