// The texture decoder the loader child runs on a model's images (server/scene/image_decode.h:
// PNG through libpng's simplified API, JPEG through libturbojpeg, TGA, BMP and GIF through
// stb_image), with limits small enough that
// libFuzzer's inputs reach them, as real models reach the real ones.
//
// Input: the bytes of one image file.
// Promises checked: decodeImage throws only scene::ModelLoadError (with a sentence); an image it
// accepts is within the dimension limit and the byte budget, and holds exactly width x height
// RGBA8 pixels; the header is checked before pixels are decoded (libFuzzer's -rss_limit_mb and
// ASan catch an allocation the limits should have refused).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_support.h"
#include "scene/image_decode.h"
#include "scene/model_loader.h"

namespace scene = myriad::scene;
using myriad::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  scene::ImageLimits limits;
  limits.maxDimension = 1024;
  limits.maxDecodedBytes = uint64_t(4) << 20;
  const uint64_t budget = limits.maxDecodedBytes;
  try {
    const scene::Image image = scene::decodeImage(bytes, "fuzz.png", limits, budget);
    require(image.width >= 1 && image.height >= 1, "an accepted image without pixels");
    require(image.width <= limits.maxDimension && image.height <= limits.maxDimension,
            "an accepted image over the dimension limit");
    require(uint64_t(image.width) * image.height * 4 <= budget,
            "an accepted image over the byte budget");
    require(image.rgba.size() == size_t(image.width) * image.height * 4,
            "an accepted image whose pixels are not width x height RGBA8");
  } catch (const scene::ModelLoadError& e) {
    require(std::string_view(e.what()).size() > 0, "a refusal without a sentence");
  }
  return 0;
}
