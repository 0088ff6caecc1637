// PNG through libpng's simplified API and JPEG through TurboJPEG: both already linked by the server
// for its own output (server/encode), both read the header alone first (png_image_begin_read_*,
// tjDecompressHeader3), so the size is checked before anything is decoded, and both report errors
// by return value rather than by aborting; stb_image's decoders of those two are less exercised.
// The formats neither reads (TGA, BMP, GIF) go to stb_image (image_decode_stb.h), header first
// as well.
#include "scene/image_decode.h"

#include <png.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include "scene/image_decode_stb.h"
#include "scene/model_loader.h"

namespace myriad::scene {

namespace {

using Kind = ModelLoadError::Kind;

[[noreturn]] void refuse(const std::string& sentence, Kind kind) {
  throw ModelLoadError(sentence, kind);
}

std::string quoted(std::string_view name) {
  std::string out(1, '\'');
  out.append(name);
  out += '\'';
  return out;
}

std::string mebibytes(uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// The checks every format shares, from the header's numbers alone.
void checkSize(uint64_t width, uint64_t height, std::string_view name, const ImageLimits& limits,
               uint64_t budgetBytes) {
  if (width == 0 || height == 0) {
    refuse("the image " + quoted(name) + " has no pixels", Kind::parse);
  }
  if (width > limits.maxDimension || height > limits.maxDimension) {
    refuse("the image " + quoted(name) + " is " + std::to_string(width) + " x " +
               std::to_string(height) + " pixels, over the texture dimension limit of " +
               std::to_string(limits.maxDimension),
           Kind::tooLarge);
  }
  if (width * height * 4 > budgetBytes) {
    refuse("its images decode to more than the limit of " + mebibytes(limits.maxDecodedBytes) +
               " of decoded image bytes per model (at the image " + quoted(name) + ")",
           Kind::tooLarge);
  }
}

Image decodePng(std::string_view bytes, std::string_view name, const ImageLimits& limits,
                uint64_t budgetBytes) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  struct Finish {
    png_image* image;
    ~Finish() { png_image_free(image); }
  } finish{&image};
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size())) {
    refuse("the PNG image " + quoted(name) + " is corrupt (" + image.message + ")", Kind::parse);
  }
  checkSize(image.width, image.height, name, limits, budgetBytes);
  image.format = PNG_FORMAT_RGBA;
  // 16-bit samples are scaled to 8 bits as they are, not treated as linear light and re-encoded:
  // a 16-bit normal map stays a normal map.
  image.flags |= PNG_IMAGE_FLAG_16BIT_sRGB;
  Image out;
  out.width = image.width;
  out.height = image.height;
  out.rgba.resize(size_t(out.width) * out.height * 4);
  if (!png_image_finish_read(&image, nullptr, out.rgba.data(), int(out.width * 4), nullptr)) {
    refuse("the PNG image " + quoted(name) + " is corrupt or truncated (" + image.message + ")",
           Kind::parse);
  }
  return out;
}

Image decodeJpeg(std::string_view bytes, std::string_view name, const ImageLimits& limits,
                 uint64_t budgetBytes) {
  std::unique_ptr<void, int (*)(tjhandle)> handle(tjInitDecompress(), tjDestroy);
  if (!handle) refuse("the JPEG decoder could not start", Kind::parse);
  auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto size = static_cast<unsigned long>(bytes.size());
  int width = 0, height = 0, subsampling = 0, colorspace = 0;
  if (tjDecompressHeader3(handle.get(), data, size, &width, &height, &subsampling, &colorspace) !=
      0) {
    refuse("the JPEG image " + quoted(name) + " is corrupt (" + tjGetErrorStr2(handle.get()) + ")",
           Kind::parse);
  }
  checkSize(uint64_t(std::max(width, 0)), uint64_t(std::max(height, 0)), name, limits,
            budgetBytes);
  Image out;
  out.width = uint32_t(width);
  out.height = uint32_t(height);
  out.rgba.resize(size_t(out.width) * out.height * 4);
  // A warning (a truncated file: "Premature end of JPEG file") stops decoding too, so that a half
  // image of grey is never shown as if it were the texture.
  if (tjDecompress2(handle.get(), data, size, out.rgba.data(), width, width * 4, height,
                    TJPF_RGBA, TJFLAG_STOPONWARNING | TJFLAG_ACCURATEDCT) != 0) {
    refuse("the JPEG image " + quoted(name) + " is corrupt or truncated (" +
               tjGetErrorStr2(handle.get()) + ")",
           Kind::parse);
  }
  return out;
}

}  // namespace

Image decodeImage(std::string_view bytes, std::string_view name, const ImageLimits& limits,
                  uint64_t budgetBytes) {
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  static constexpr unsigned char kJpeg[3] = {0xFF, 0xD8, 0xFF};
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPng, 8) == 0) {
    return decodePng(bytes, name, limits, budgetBytes);
  }
  if (bytes.size() >= 3 && std::memcmp(bytes.data(), kJpeg, 3) == 0) {
    return decodeJpeg(bytes, name, limits, budgetBytes);
  }
  if (bytes.empty()) refuse("the image " + quoted(name) + " is empty", Kind::parse);
  if (const std::optional<StbHeader> header = stbHeader(bytes)) {
    checkSize(header->width, header->height, name, limits, budgetBytes);
    return stbDecode(bytes, name, *header);
  }
  refuse("the image " + quoted(name) +
             " is none of PNG, JPEG, TGA, BMP and GIF (the formats this server decodes)",
         Kind::unsupported);
}

}  // namespace myriad::scene
