// TGA, BMP and GIF textures (common in OBJ, FBX and Collada files: the Collada duck's is a
// TGA) through Debian's stb_image, compiled here with internal linkage (STB_IMAGE_STATIC: libdraco,
// which Assimp loads, exports its own older stbi_ functions, as loader/hdr_decode.cpp says) and
// only these three readers. PNG and JPEG stay with libpng and TurboJPEG (image_decode.cpp).
//
// The same bounds as those: the size from the header (stbi_info) is checked against the limits
// before a pixel is decoded; the bytes are read through callbacks that see a read past the end (a
// truncated file, which stb_image would fill with zeros and decode without a word) and refuse it.
#include "scene/image_decode_stb.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_TGA
#define STBI_ONLY_BMP
#define STBI_ONLY_GIF
// Not PSD: its reader (stb_image 2.27) converts floats outside 0-255 to bytes when it takes the
// white matte off a four-channel file (undefined behaviour; fuzz_texture found it in minutes).
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#define STBI_NO_HDR
// A second line behind ImageLimits::maxDimension (checked first): no reader allocates for more.
#define STBI_MAX_DIMENSIONS (1 << 14)
#include <stb_image.h>

#include "scene/bounded_reader.h"

namespace myriad::scene {

namespace {

constexpr stbi_io_callbacks kCallbacks{BoundedReader::read, BoundedReader::skip,
                                       BoundedReader::eof};

}  // namespace

std::optional<StbHeader> stbHeader(std::string_view bytes) {
  if (bytes.empty() || bytes.size() > size_t(INT32_MAX)) return std::nullopt;
  int width = 0, height = 0, channels = 0;
  if (stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), int(bytes.size()),
                            &width, &height, &channels) == 0 ||
      width <= 0 || height <= 0) {
    return std::nullopt;
  }
  return StbHeader{uint32_t(width), uint32_t(height)};
}

Image stbDecode(std::string_view bytes, std::string_view name, const StbHeader& header) {
  std::string quoted(1, '\'');
  quoted.append(name);
  quoted += '\'';
  BoundedReader reader{bytes};
  int width = 0, height = 0, channels = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
      stbi_load_from_callbacks(&kCallbacks, &reader, &width, &height, &channels, 4),
      stbi_image_free);
  if (!pixels) {
    throw ModelLoadError("the image " + quoted + " is corrupt (" + stbi_failure_reason() + ")",
                         ModelLoadError::Kind::parse);
  }
  if (reader.readPastEnd) {
    throw ModelLoadError("the image " + quoted + " is truncated (its pixels end before the file does "
                         "say they should)",
                         ModelLoadError::Kind::parse);
  }
  // The header stbi_info read is the one the reader decoded: a file whose two readings differ is
  // not one image.
  if (uint32_t(width) != header.width || uint32_t(height) != header.height) {
    throw ModelLoadError("the image " + quoted + " is corrupt (its header reads two ways)",
                         ModelLoadError::Kind::parse);
  }
  Image out;
  out.width = header.width;
  out.height = header.height;
  out.rgba.assign(pixels.get(), pixels.get() + size_t(out.width) * out.height * 4);
  return out;
}

}  // namespace myriad::scene
