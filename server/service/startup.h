// The pieces of start-up that main() strings together and tests can call: which scene to serve,
// and how to describe the device in the log.
#pragma once

#include <string>
#include <string_view>

#include "render/device_summary.h"
#include "scene/light_generator.h"
#include "scene/scene.h"
#include "service/options.h"

namespace myriad::service {

// The built-in scene, or options.model with options.lights generated lights spread through and around it
// (sized to the model, so a 10 cm object and a 100 m hall both get visible pools). The model is
// parsed in the loader child (loader/loader.h); throws loader::ModelRejected, a
// scene::ModelLoadError.
scene::Scene buildScene(const Options& options);

// `count` lights from `seed` spread through and around `bounds` (grown by a tenth of the diagonal
// on every side), with radii and intensities sized to it: what --model and POST .../lights/generate
// use unless told otherwise.
scene::LightGeneration lightGenerationAround(const scene::Bounds& bounds, uint32_t count,
                                             uint64_t seed);

// The lights a session's model gets when only a count and a seed are named (POST .../lights/
// generate with the defaults, a snapshot's lights.generated, lights fitted to a new model): the
// built-in scene's own layout for the built-in model (scene::builtinLightGeneration, so that a
// snapshot of a new session restores the very lights it started with), lightGenerationAround
// the model's bounds for every other.
scene::LightGeneration defaultLightGeneration(std::string_view modelSource,
                                              const scene::Bounds& bounds, uint32_t count,
                                              uint64_t seed);

// "llvmpipe (LLVM 15.0.6, 256 bits) [device 0, cpu], driver llvmpipe (Mesa 22.3.6), Vulkan 1.3.230"
std::string describeDevice(const render::DeviceSummary& device);

// "http://127.0.0.1:8080" ("http://[::1]:8080" for IPv6 hosts).
std::string serverUrl(const std::string& host, uint16_t port);

}  // namespace myriad::service
