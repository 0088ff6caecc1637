#include "loader/hdr_decode.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

// stb_image's implementation compiled here, from Debian's header, with internal linkage
// (STB_IMAGE_STATIC) and the HDR reader alone: libdraco, which Assimp loads, exports its own older
// copy of every stbi_ function, and the dynamic linker bound our calls to that one (seen in the
// fuzz harness's stacks). Static functions cannot be interposed.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_HDR
#define STBI_NO_STDIO
#include <stb_image.h>

#include "scene/bounded_reader.h"
#include "scene/model_loader.h"

namespace myriad::loader {

namespace {

using Kind = scene::ModelLoadError::Kind;

[[noreturn]] void refuse(Kind kind, const std::string& sentence) {
  throw scene::ModelLoadError(sentence, kind);
}

// The byte handed out past the end of the data: an RLE run of one. stb_image 2.27's run-length
// scanline loop never advances on a zero count, and zeros are what it reads past the end by
// itself, so a truncated run-length .hdr looped forever (the fuzz harness found it). checkPixelData
// below refuses such files before stb_image sees them; this is the second line, should the walk
// and stb_image ever disagree: with runs of one every scanline ends, and the file is refused as
// truncated.
constexpr char kPastEndFill = char(0x81);

// Where the pixel data starts, reading the header as stb_image does: the magic line, lines up to
// an empty one, then the resolution line. npos when the header never ends.
size_t pixelDataStart(std::string_view bytes) {
  size_t at = 0;
  auto line = [&]() -> std::optional<std::string_view> {
    const size_t end = bytes.find('\n', at);
    if (end == std::string_view::npos) return std::nullopt;
    const std::string_view text = bytes.substr(at, end - at);
    at = end + 1;
    return text;
  };
  if (!line()) return std::string_view::npos;  // the magic line
  for (;;) {
    const std::optional<std::string_view> text = line();
    if (!text) return std::string_view::npos;
    if (text->empty()) break;
  }
  if (!line()) return std::string_view::npos;  // the resolution line
  return at;
}

// Walks the pixel data as stb_image will read it (flat pixels, or run-length scanlines: "2 2
// width", then per channel runs and literals), without decoding. stb_image reads zeros past the
// end of the data and loops forever on a literal of length 0, so a short or hostile file is
// refused here, before it is handed over. Returns the problem, or "" when the data is whole.
std::string pixelDataProblem(std::string_view bytes, size_t at, uint32_t width, uint32_t height) {
  const std::string truncated = "truncated";
  auto have = [&](uint64_t n) { return bytes.size() - at >= n; };
  const uint64_t flatBytes = uint64_t(width) * height * 4;
  if (width < 8 || width >= 32768) return have(flatBytes) ? "" : truncated;
  for (uint32_t y = 0; y < height; ++y) {
    if (!have(4)) return truncated;
    const auto c1 = uint8_t(bytes[at]), c2 = uint8_t(bytes[at + 1]), c3 = uint8_t(bytes[at + 2]);
    if (c1 != 2 || c2 != 2 || (c3 & 0x80) != 0) {
      // Not run-length encoded: stb_image reads the whole image flat from here.
      return have(flatBytes) ? "" : truncated;
    }
    const uint32_t length = (uint32_t(c3) << 8) | uint8_t(bytes[at + 3]);
    at += 4;
    if (length != width) return "a run-length scanline's length differs from the image's width";
    for (int channel = 0; channel < 4; ++channel) {
      uint32_t left = width;
      while (left > 0) {
        if (!have(1)) return truncated;
        uint32_t count = uint8_t(bytes[at++]);
        if (count > 128) {
          count -= 128;
          if (!have(1)) return truncated;
          ++at;
        } else {
          if (count == 0) return "a run-length scanline holds a run of length 0";
          if (count <= left && !have(count)) return truncated;
          if (count <= left) at += count;
        }
        if (count > left) return "a run-length scanline's runs overflow its width";
        left -= count;
      }
    }
  }
  return "";
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

  const size_t start = pixelDataStart(bytes);
  if (start == std::string_view::npos) {
    refuse(Kind::parse, file + " has a bad Radiance header (it never ends).");
  }
  const std::string problem = pixelDataProblem(bytes, start, uint32_t(width), uint32_t(height));
  if (problem == "truncated") {
    refuse(Kind::parse, file + " is truncated: its pixel data ends before the " +
                            std::to_string(width) + " x " + std::to_string(height) +
                            " pixels its header declares.");
  }
  if (!problem.empty()) refuse(Kind::parse, file + " has corrupt pixel data: " + problem + ".");

  scene::BoundedReader reader{bytes, 0, false, kPastEndFill};
  const stbi_io_callbacks callbacks{scene::BoundedReader::read, scene::BoundedReader::skip,
                                    scene::BoundedReader::eof};
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
