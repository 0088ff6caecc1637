// The loader child's Radiance .hdr decoder (server/loader/hdr_decode.h) on valid, truncated and
// hostile files, including the inputs fuzz_image found.
#include <doctest/doctest.h>

#include <chrono>
#include <cstdint>
#include <string>

#include "loader/hdr_decode.h"
#include "scene/model_loader.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;

namespace {

// A width x height run-length .hdr: each scanline "2 2 hi lo", then each channel as runs.
std::string rleHdr(int width, int height) {
  std::string file = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(height) +
                     " +X " + std::to_string(width) + "\n";
  for (int y = 0; y < height; ++y) {
    file += {char(2), char(2), char(width >> 8), char(width & 255)};
    for (int channel = 0; channel < 4; ++channel) {
      // One run for the whole scanline per channel: mantissas 128, exponent 129 -> 1.0.
      int left = width;
      while (left > 0) {
        const int run = left < 127 ? left : 127;
        file += char(128 + run);
        file += char(channel == 3 ? 129 : 128);
        left -= run;
      }
    }
  }
  return file;
}

std::string refusal(const std::string& bytes) {
  try {
    loader::decodeHdr(bytes, "test.hdr", loader::HdrLimits{});
  } catch (const scene::ModelLoadError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("hdr: a run-length .hdr decodes to the environment size with its radiance") {
  scene::EnvironmentImage image = loader::decodeHdr(rleHdr(64, 32), "test.hdr", loader::HdrLimits{});
  REQUIRE(image.rgb.size() == size_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3);
  for (float v : image.rgb) CHECK(v == doctest::Approx(1.0f));
}

TEST_CASE("hdr: a truncated run-length .hdr is refused at once, wherever it ends") {
  // stb_image 2.27 looped forever on these (a zero run count, which it reads past the end): the
  // loader child burned its whole CPU limit. fuzz_image found it.
  const std::string whole = rleHdr(32, 16);
  for (size_t cut : {whole.size() - 1, whole.size() - 100, whole.size() / 2, size_t(60)}) {
    CAPTURE(cut);
    const auto start = std::chrono::steady_clock::now();
    const std::string sentence = refusal(whole.substr(0, cut));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    CHECK(sentence.find("truncated") != std::string::npos);
    CHECK(seconds < 1.0);
  }
}

TEST_CASE("hdr: zero run counts inside the data end, and are refused") {
  std::string file = rleHdr(16, 4);
  const size_t header = file.find("+X 16\n") + 6;
  // Replace the first scanline's runs with zero counts: each is a "dump" of nothing.
  for (size_t i = header + 4; i < header + 40 && i < file.size(); ++i) file[i] = '\0';
  const auto start = std::chrono::steady_clock::now();
  CHECK_FALSE(refusal(file).empty());
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(1));
}

TEST_CASE("hdr: dimensions over the limits are refused from the header, before decoding") {
  const std::string sentence =
      refusal("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n");
  CHECK(sentence.find("100000 x 100000") != std::string::npos);
  CHECK(sentence.find("over the limit") != std::string::npos);
  CHECK(refusal("P6\n4 4\n255\n").find("not a Radiance") != std::string::npos);
}
