// Decoding a model's texture images (PNG, JPEG, TGA, BMP, GIF) from untrusted bytes. Runs only in the loader child
// (loader/child.cpp), under its memory and CPU limits, but bounds its own work first: the size is
// read from the image's header and checked against the limits before a pixel is decoded or a byte
// reserved, so a 30,000 x 30,000 PNG of a few hundred bytes is refused without allocating.
// One function, so that a fuzz harness can drive it alone (tests/fuzz).
#pragma once

#include <cstdint>
#include <string_view>

#include "scene/scene.h"

namespace myriad::scene {

// The limits every model's images are held to (docs/ARCHITECTURE.md, "Texture images"). Over one,
// the model is refused with a ModelLoadError of Kind::tooLarge naming the limit (a 422 problem).
struct ImageLimits {
  uint32_t maxDimension = 8192;                // width and height, each
  uint64_t maxDecodedBytes = uint64_t(256) << 20;  // RGBA8 bytes of all a model's images together
  uint32_t maxImages = 256;                    // distinct images one model uses
};

// Decodes a PNG or JPEG (told apart by their signatures), else a TGA, BMP or GIF's first frame
// (stb_image's readers, which know their own headers) to RGBA8, rows top first, no colour
// conversion (base colour maps stay sRGB-encoded, data maps linear: the renderer picks the view).
// `budgetBytes` is what is left of ImageLimits::maxDecodedBytes for this model; `name` names the
// image in messages. Throws ModelLoadError: Kind::tooLarge over a dimension or the budget,
// Kind::unsupported for another format, Kind::parse for a corrupt or truncated file.
Image decodeImage(std::string_view bytes, std::string_view name, const ImageLimits& limits,
                  uint64_t budgetBytes);

}  // namespace myriad::scene
