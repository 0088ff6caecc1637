#include "loader/hdr_decode.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

// stb_image's implementation compiled here, from Debian's header, with internal linkage
// (STB_IMAGE_STATIC) and the HDR reader alone: libdraco, which Assimp loads, exports its own older
// copy of every stbi_ function, and the dynamic linker bound our calls to that one (seen in the
// fuzz_image harness's stacks). Static functions cannot be interposed.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_HDR
#define STBI_NO_STDIO
#include <stb_image.h>

#include "scene/model_loader.h"

namespace myriad::loader {

namespace {

using Kind = scene::ModelLoadError::Kind;

[[noreturn]] void refuse(Kind kind, const std::string& sentence) {
  throw scene::ModelLoadError(sentence, kind);
}

// stb_image reads past the end of a truncated file as zeros without saying so; reading through
// callbacks shows it: the decoder asking for bytes after the last one means the file is short.
struct Reader {
  std::string_view bytes;
  size_t at = 0;
  bool readPastEnd = false;
};

// The byte handed out past the end of the data: an RLE run of one. stb_image 2.27's run-length
// scanline loop never advances on a zero count, and zeros are what it reads past the end by
// itself, so a truncated run-length .hdr looped forever (fuzz_image found it: the child burned its
// whole CPU limit). With runs of one every scanline ends; the result is refused as truncated.
constexpr char kPastEndFill = char(0x81);

int readBytes(void* user, char* out, int size) {
  auto* r = static_cast<Reader*>(user);
  const size_t left = r->bytes.size() - r->at;
  if (left == 0) {
    r->readPastEnd = true;
    std::memset(out, kPastEndFill, size_t(size));
    return size;
  }
  const size_t n = std::min(left, size_t(size));
  std::memcpy(out, r->bytes.data() + r->at, n);
  r->at += n;
  return int(n);
}

void skipBytes(void* user, int n) {
  auto* r = static_cast<Reader*>(user);
  if (n < 0) {
    r->at -= std::min(r->at, size_t(-n));
  } else if (size_t(n) > r->bytes.size() - r->at) {
    r->at = r->bytes.size();
    r->readPastEnd = true;
  } else {
    r->at += size_t(n);
  }
}

int atEnd(void* user) {
  auto* r = static_cast<Reader*>(user);
  return r->at >= r->bytes.size() ? 1 : 0;
}

struct StbFree {
  void operator()(float* p) const { stbi_image_free(p); }
};

}  // namespace

scene::EnvironmentImage decodeHdr(std::string_view bytes, std::string_view name,
                                  const HdrLimits& limits) {
  const std::string file = "The environment image '" + std::string(name) + "'";
  if (bytes.empty()) refuse(Kind::empty, file + " is empty.");
  if (bytes.size() > size_t(INT32_MAX)) refuse(Kind::tooLarge, file + " is larger than 2 GiB.");
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int length = int(bytes.size());
  if (!stbi_is_hdr_from_memory(data, length)) {
    refuse(Kind::parse, file + " is not a Radiance .hdr: it does not start with \"#?RADIANCE\" or "
                               "\"#?RGBE\".");
  }
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(data, length, &width, &height, &channels)) {
    refuse(Kind::parse, file + " has a bad Radiance header (" +
                            std::string(stbi_failure_reason() ? stbi_failure_reason() : "unreadable") +
                            ").");
  }
  if (width <= 0 || height <= 0) refuse(Kind::parse, file + " has no pixels.");
  if (uint32_t(width) > limits.maxWidth || uint32_t(height) > limits.maxHeight) {
    refuse(Kind::tooLarge, file + " is " + std::to_string(width) + " x " + std::to_string(height) +
                               " pixels, over the limit of " + std::to_string(limits.maxWidth) +
                               " x " + std::to_string(limits.maxHeight) + ".");
  }

  Reader reader{bytes};
  const stbi_io_callbacks callbacks{readBytes, skipBytes, atEnd};
  int w = 0, h = 0, n = 0;
  std::unique_ptr<float, StbFree> pixels(stbi_loadf_from_callbacks(&callbacks, &reader, &w, &h, &n, 3));
  if (!pixels) {
    refuse(Kind::parse, file + " could not be decoded (" +
                            std::string(stbi_failure_reason() ? stbi_failure_reason() : "unknown") +
                            ").");
  }
  if (reader.readPastEnd) {
    refuse(Kind::parse, file + " is truncated: its pixel data ends before the " +
                            std::to_string(width) + " x " + std::to_string(height) +
                            " pixels its header declares.");
  }
  if (w != width || h != height) refuse(Kind::parse, file + " changed size while decoding.");
  std::vector<float> rgb(pixels.get(), pixels.get() + size_t(w) * h * 3);
  pixels.reset();
  for (float& v : rgb) {
    if (!std::isfinite(v)) refuse(Kind::parse, file + " holds a non-finite radiance.");
    v = std::clamp(v, 0.0f, kMaxEnvironmentRadiance);
  }
  return scene::resampleEquirect(rgb, uint32_t(w), uint32_t(h));
}

}  // namespace myriad::loader
