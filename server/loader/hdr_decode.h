// The loader child's side of an environment image: a Radiance .hdr (RGBE) decoded with Debian's
// stb_image (libstb-dev) and resampled to the renderer's environment size. Runs only in the
// child (the bytes are untrusted); the parent gets 256x128 floats back and checks them again.
#pragma once

#include <cstdint>
#include <string_view>

#include "scene/environment_map.h"

namespace myriad::loader {

// What an .hdr may be. Checked from the header, before any pixel is decoded: at the largest,
// decoding takes 8192 x 4096 x 12 bytes = 384 MiB inside the child's 2 GiB address space.
struct HdrLimits {
  uint32_t maxWidth = 8192;
  uint32_t maxHeight = 4096;
};

// The brightest radiance kept: RGBE reaches 1e38, which would overflow the half-float HDR target
// once shaded; real skies with the sun in them stay far below.
inline constexpr float kMaxEnvironmentRadiance = 65504.0f / 4.0f;

// Decodes `bytes` (a whole .hdr file; `name` is for messages). Throws scene::ModelLoadError with
// one sentence naming the problem: not a Radiance file or a bad header (parse), dimensions over
// the limits (tooLarge, before decoding), pixel data shorter than the header promises (parse,
// "truncated"), or an image that is not 2:1 equirectangular... (any size is accepted: it is
// resampled).
scene::EnvironmentImage decodeHdr(std::string_view bytes, std::string_view name,
                                  const HdrLimits& limits);

}  // namespace myriad::loader
