// The texture formats decodeImage (image_decode.h) reads through stb_image: TGA, BMP and GIF
// (its first frame). Internal to decodeImage, which checks the header's size against the limits
// between the two calls.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "scene/model_loader.h"
#include "scene/scene.h"

namespace myriad::scene {

struct StbHeader {
  uint32_t width = 0;
  uint32_t height = 0;
};

// The size from the header when the bytes are one of the three formats; nullopt otherwise.
std::optional<StbHeader> stbHeader(std::string_view bytes);

// Decodes to RGBA8, rows top first (stb_image flips BMP and bottom-up TGA itself). Throws
// ModelLoadError (Kind::parse) for a corrupt or truncated file.
Image stbDecode(std::string_view bytes, std::string_view name, const StbHeader& header);

}  // namespace myriad::scene
