#include "service/startup.h"

#include <glm/glm.hpp>

#include "loader/loader.h"
#include "protocol/constants.h"
#include "scene/builtin_scene.h"
#include "scene/light_generator.h"
#include "scene/model_loader.h"

namespace myriad::service {
namespace {

// Of the model's diagonal, on every side of its bounds.
constexpr float kLightMargin = 0.1f;

}  // namespace

scene::Scene buildScene(const Options& options) {
  if (!options.model) return scene::makeBuiltinScene(options.lights, options.seed);

  // In the loader child, like an upload: a file that crashes or exhausts Assimp is one line on
  // stderr and exit status 1, not a dead process.
  scene::Scene scene = loader::loadModelFile(*options.model);
  const scene::Bounds bounds = scene.bounds();
  if (options.lights == 0 || bounds.empty()) return scene;

  scene::LightGeneration lights = lightGenerationAround(bounds, options.lights, options.seed);
  std::vector<scene::PointLight> generated = scene::generateLights(lights);
  scene.lights.insert(scene.lights.end(), generated.begin(), generated.end());
  return scene;
}

scene::LightGeneration defaultLightGeneration(std::string_view modelSource,
                                              const scene::Bounds& bounds, uint32_t count,
                                              uint64_t seed) {
  if (modelSource == protocol::kBuiltinModel) return scene::builtinLightGeneration(count, seed);
  return lightGenerationAround(bounds, count, seed);
}

scene::LightGeneration lightGenerationAround(const scene::Bounds& bounds, uint32_t count,
                                             uint64_t seed) {
  scene::LightGeneration lights;
  lights.count = count;
  lights.seed = seed;
  if (bounds.empty()) {
    lights.bounds.min = glm::vec3(-1.0f);
    lights.bounds.max = glm::vec3(1.0f);
    return lights;
  }
  // Radii as fractions of the model's diagonal: large enough that a light's pool covers a visible
  // patch, small enough that many lights stay distinguishable instead of summing to a wash.
  const float diagonal = glm::length(bounds.size());
  // A margin around the model: lights strictly inside a closed mesh light nothing a camera sees.
  const glm::vec3 margin(kLightMargin * diagonal);
  lights.bounds.min = bounds.min - margin;
  lights.bounds.max = bounds.max + margin;
  lights.minRadius = std::max(0.04f * diagonal, 1.0e-3f);
  lights.maxRadius = std::max(0.15f * diagonal, 2.0e-3f);
  lights.minIntensity = 2.0f;
  lights.maxIntensity = 6.0f;
  lights.falloff = 4.0f;
  return lights;
}

std::string describeDevice(const render::DeviceSummary& device) {
  std::string text = device.name + " [device " + std::to_string(device.index) + ", " + device.type +
                     "], driver " + device.driverName;
  if (!device.driverInfo.empty()) text += " (" + device.driverInfo + ")";
  return text + ", Vulkan " + device.apiVersion;
}

std::string serverUrl(const std::string& host, uint16_t port) {
  bool ipv6 = host.find(':') != std::string::npos;
  return "http://" + (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

}  // namespace myriad::service
