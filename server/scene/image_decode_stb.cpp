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

namespace myriad::scene {

namespace {

struct Reader {
  std::string_view bytes;
  size_t at = 0;
  bool readPastEnd = false;
};

// stb_image reads through a buffer of its own, asking for more than is left near the end (a
// short read is normal); it asks again only once it needs a byte beyond the last one.
int readBytes(void* user, char* out, int size) {
  auto* r = static_cast<Reader*>(user);
  const size_t left = r->bytes.size() - r->at;
  if (left == 0) {
    r->readPastEnd = true;
    return 0;
  }
  const size_t n = std::min(left, size_t(std::max(size, 0)));
  std::memcpy(out, r->bytes.data() + r->at, n);
  r->at += n;
  return int(n);
}

void skipBytes(void* user, int n) {
  auto* r = static_cast<Reader*>(user);
  if (n < 0) {
    r->at -= std::min(r->at, size_t(-int64_t(n)));
    return;
  }
  const size_t left = r->bytes.size() - r->at;
  if (size_t(n) > left) r->readPastEnd = true;
  r->at += std::min(left, size_t(n));
}

// Asked before a read, to know whether one could give more: not itself a read past the end.
int atEnd(void* user) {
  const auto* r = static_cast<const Reader*>(user);
  return r->at >= r->bytes.size() ? 1 : 0;
}

constexpr stbi_io_callbacks kCallbacks{readBytes, skipBytes, atEnd};

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
  Reader reader{bytes};
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
