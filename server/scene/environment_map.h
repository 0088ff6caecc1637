// An environment light's source image: an equirectangular radiance map at the size the renderer
// prefilters from (render/environment.cpp; shaders/shared_types.h MYRIAD_ENV_SOURCE_*, checked
// equal in render/gpu_types.h). An uploaded .hdr of any size is resampled to it (in the loader
// child, server/loader/), so the server holds and uploads a bounded 384 KiB per environment.
#pragma once

#include <cstdint>
#include <vector>

namespace myriad::scene {

inline constexpr uint32_t kEnvironmentWidth = 256;
inline constexpr uint32_t kEnvironmentHeight = 128;

// Linear RGB radiance, 3 floats per texel, rows top first (row 0 looks up, +Y); u = 0.5 looks
// down -Z (shaders/environment.glsl). Always kEnvironmentWidth x kEnvironmentHeight.
struct EnvironmentImage {
  std::vector<float> rgb;
};

// Resamples an equirectangular RGB float image (rows top first) of any size to the environment
// size: each output texel is the mean of the input texels whose centres fall inside it, or, where
// none does (an input smaller than the output), the input texel under the output texel's centre.
// Throws std::invalid_argument for an empty image or a pixel array of the wrong size.
EnvironmentImage resampleEquirect(const std::vector<float>& rgb, uint32_t width, uint32_t height);

}  // namespace myriad::scene
