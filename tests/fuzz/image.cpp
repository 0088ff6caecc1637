// The image decoders as the loader child runs them on untrusted bytes: the Radiance .hdr of an
// environment upload (server/loader/hdr_decode.h, stb_image) and the resampling to the renderer's
// environment size.
//
// Input: the bytes of one image file.
// Promises checked: decodeHdr throws only scene::ModelLoadError (with a sentence); an image it
// accepts has exactly kEnvironmentWidth x kEnvironmentHeight x 3 finite, non-negative values no
// brighter than kMaxEnvironmentRadiance; no input allocates past the header's checked limits
// (libFuzzer's -rss_limit_mb and ASan catch the rest).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_support.h"
#include "loader/hdr_decode.h"
#include "scene/model_loader.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;
using myriad::fuzz::require;

namespace {

void fuzzHdr(std::string_view bytes) {
  // Limits small enough that libFuzzer's inputs reach them, as real uploads reach the real ones.
  loader::HdrLimits limits;
  limits.maxWidth = 1024;
  limits.maxHeight = 512;
  scene::EnvironmentImage image;
  try {
    image = loader::decodeHdr(bytes, "fuzz.hdr", limits);
  } catch (const scene::ModelLoadError& e) {
    require(std::string_view(e.what()).size() > 0, "a refusal without a sentence");
    return;
  }
  require(image.rgb.size() == size_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3,
          "an accepted .hdr not resampled to the environment size");
  for (float v : image.rgb) {
    require(std::isfinite(v) && v >= 0.0f && v <= loader::kMaxEnvironmentRadiance,
            "an accepted .hdr with a value out of range");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  fuzzHdr(bytes);
  return 0;
}
