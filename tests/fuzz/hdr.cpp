// The environment image decoder the loader child runs on an uploaded .hdr
// (server/loader/hdr_decode.h): Debian's stb_image behind our header checks and truncation
// detection, then the resampling to the environment size.
//
// Input: the bytes of an upload.
// Promises checked: decodeHdr throws only scene::ModelLoadError (with a sentence); an image it
// returns is exactly 256 x 128 x 3 floats, each finite and in [0, kMaxEnvironmentRadiance]. The
// limits are lowered (512 x 256) so that no input makes the harness decode a huge image.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_support.h"
#include "loader/hdr_decode.h"
#include "scene/model_loader.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;
using myriad::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  scene::EnvironmentImage image;
  try {
    image = loader::decodeHdr(bytes, "fuzz.hdr", loader::HdrLimits{512, 256});
  } catch (const scene::ModelLoadError& e) {
    require(std::string_view(e.what()).size() > 0, "a refusal without a sentence");
    return 0;
  }
  require(image.rgb.size() == size_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3,
          "an image of the wrong size");
  for (const float v : image.rgb) {
    require(std::isfinite(v) && v >= 0.0f && v <= loader::kMaxEnvironmentRadiance,
            "a radiance out of range");
  }
  return 0;
}
