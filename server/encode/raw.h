// format=raw: a frame's float values as bytes. Plain CPU code, like the image encoders.
#pragma once

#include <cstdint>
#include <vector>

#include "render/frame.h"

namespace myriad::encode {

// N little-endian float32 channels per pixel, rows top first, where N and the channels' meaning
// are render::rawChannels(target) (the rest of the renderer's 4 floats are dropped). `frame` must
// be a raw frame (FrameSettings::raw): throws std::invalid_argument when frame.data does not hold
// width * height * 4 floats.
std::vector<uint8_t> packRaw(const render::Frame& frame, render::Target target);

}  // namespace myriad::encode
