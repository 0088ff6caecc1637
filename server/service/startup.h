// The pieces of start-up that main() strings together and tests can call: which scene to serve,
// and how to describe the device in the log.
#pragma once

#include <string>

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

// "llvmpipe (LLVM 15.0.6, 256 bits) [device 0, cpu], driver llvmpipe (Mesa 22.3.6), Vulkan 1.3.230"
std::string describeDevice(const render::DeviceSummary& device);

// "http://127.0.0.1:8080" ("http://[::1]:8080" for IPv6 hosts).
std::string serverUrl(const std::string& host, uint16_t port);

}  // namespace myriad::service
