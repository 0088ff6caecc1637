// format=raw: a frame's float values as bytes. Plain CPU code, like the image encoders; it knows
// pixels and channel counts, not the renderer's types.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace myriad::encode {

// The first `channels` (1..4) of each pixel of `pixels` (4 floats per pixel, rows top first, as
// the renderer reads a raw frame back) as little-endian float32, rows top first; the rest of each
// pixel's 4 floats are dropped. Which channels mean what is the caller's business
// (render::rawChannels(target)). Throws std::invalid_argument when `pixels` does not hold
// width * height * 4 floats or `channels` is outside 1..4.
std::vector<uint8_t> packRaw(uint32_t width, uint32_t height, std::span<const float> pixels,
                             size_t channels);

}  // namespace myriad::encode
