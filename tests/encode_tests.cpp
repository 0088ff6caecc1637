// JPEG and raw encoding of frames: JPEGs decode (with libturbojpeg itself) to the same size and
// close to the source; raw packing is exact, byte for byte.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <span>
#include <utility>
#include <vector>
#include <cstring>
#include <memory>
#include <thread>
#include <tuple>

#include <turbojpeg.h>

#include "encode/jpeg.h"
#include "encode/png.h"
#include "encode/png_writer.h"
#include "encode/raw.h"
#include "render/frame.h"

using namespace myriad;

namespace {

// Smooth gradients with a soft disc: the kind of content JPEG keeps well at high quality.
std::vector<uint8_t> testImage(uint32_t w, uint32_t h) {
  std::vector<uint8_t> rgba(size_t(w) * h * 4);
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = &rgba[(size_t(y) * w + x) * 4];
      float dx = x - w * 0.5f, dy = y - h * 0.5f;
      float disc = std::exp(-(dx * dx + dy * dy) / (0.08f * w * h));
      p[0] = uint8_t(255.0f * x / (w - 1));
      p[1] = uint8_t(255.0f * y / (h - 1));
      p[2] = uint8_t(60.0f + 180.0f * disc);
      p[3] = 255;
    }
  }
  return rgba;
}

struct Decoded {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;
};

Decoded decodeJpeg(const std::vector<uint8_t>& jpeg) {
  std::unique_ptr<void, int (*)(void*)> handle(tjInitDecompress(), tjDestroy);
  REQUIRE(handle);
  Decoded d;
  int subsampling = 0, colorspace = 0;
  REQUIRE(tjDecompressHeader3(handle.get(), jpeg.data(), jpeg.size(), &d.width, &d.height,
                              &subsampling, &colorspace) == 0);
  d.rgba.resize(size_t(d.width) * d.height * 4);
  REQUIRE(tjDecompress2(handle.get(), jpeg.data(), jpeg.size(), d.rgba.data(), d.width, 0, d.height,
                        TJPF_RGBA, 0) == 0);
  return d;
}

struct Error {
  double mean = 0;
  int max = 0;
};

Error difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  REQUIRE(a.size() == b.size());
  Error e;
  size_t n = 0;
  for (size_t i = 0; i < a.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      int d = std::abs(int(a[i + c]) - int(b[i + c]));
      e.mean += d;
      e.max = std::max(e.max, d);
      ++n;
    }
  }
  e.mean /= double(n);
  return e;
}

}  // namespace

TEST_CASE("JPEG decodes to the same size and close to the source, tighter at higher quality") {
  const uint32_t w = 96, h = 64;  // not a multiple of the 16-pixel MCU in both directions
  std::vector<uint8_t> source = testImage(w, 70);
  source.resize(size_t(w) * h * 4);  // keeps rows 0..63 of the 70-row image: an uneven edge
  Error previous{1e9, 0};
  size_t previousBytes = 0;
  for (int quality : {50, 85, 95, 100}) {
    std::vector<uint8_t> jpeg = encode::encodeJpeg(source, w, h, quality);
    REQUIRE(jpeg.size() > 4);
    CHECK(jpeg[0] == 0xFF);  // SOI marker
    CHECK(jpeg[1] == 0xD8);
    Decoded d = decodeJpeg(jpeg);
    CHECK(d.width == int(w));
    CHECK(d.height == int(h));
    Error e = difference(source, d.rgba);
    MESSAGE("quality " << quality << ": " << jpeg.size() << " bytes, mean error " << e.mean
                       << ", max " << e.max);
    CHECK(e.mean < (quality >= 85 ? 1.5 : 3.0));
    CHECK(e.max < (quality >= 95 ? 8 : 24));
    CHECK(e.mean <= previous.mean + 0.05);
    CHECK(jpeg.size() > previousBytes);
    previous = e;
    previousBytes = jpeg.size();
  }
}

TEST_CASE("JPEG of a 1x1 image and quality 1 still decode") {
  std::vector<uint8_t> red = {200, 30, 40, 255};
  Decoded d = decodeJpeg(encode::encodeJpeg(red, 1, 1, 100));
  REQUIRE(d.width == 1);
  CHECK(std::abs(int(d.rgba[0]) - 200) <= 3);
  CHECK(std::abs(int(d.rgba[1]) - 30) <= 3);
  CHECK(std::abs(int(d.rgba[2]) - 40) <= 3);
  std::vector<uint8_t> image = testImage(32, 32);
  Decoded low = decodeJpeg(encode::encodeJpeg(image, 32, 32, 1));
  CHECK(low.width == 32);
  CHECK(low.height == 32);
}

TEST_CASE("JPEG rejects bad sizes and qualities by name") {
  std::vector<uint8_t> image = testImage(8, 8);
  CHECK_THROWS_WITH_AS(encode::encodeJpeg(image, 8, 8, 0), "JPEG quality 0 is outside 1..100",
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(encode::encodeJpeg(image, 8, 8, 101), "JPEG quality 101 is outside 1..100",
                       std::invalid_argument);
  CHECK_THROWS_AS(encode::encodeJpeg(image, 8, 7, 80), std::invalid_argument);
  CHECK_THROWS_AS(encode::encodeJpeg(image, 0, 8, 80), std::invalid_argument);
  CHECK_THROWS_AS(encode::encodeJpeg({}, 70000, 1, 80), std::invalid_argument);
}

TEST_CASE("raw packing keeps exactly the target's channels, little-endian, rows top first") {
  render::Frame frame;
  frame.width = 3;
  frame.height = 2;
  for (uint32_t i = 0; i < frame.width * frame.height * 4; ++i) {
    frame.data.push_back(i % 4 == 3 ? 1.0f : -1.5f + 0.25f * float(i) + (i == 5 ? 1e-30f : 0.0f));
  }
  frame.data[9] = std::nanf("");  // values pass through untouched, whatever they are
  for (render::Target target : {render::Target::Final, render::Target::Uv, render::Target::Depth,
                                render::Target::Clusters, render::Target::LightCount}) {
    const size_t channels = render::rawChannels(target).size();
    std::vector<uint8_t> bytes = encode::packRaw(frame.width, frame.height, frame.data, channels);
    CAPTURE(render::targetName(target));
    REQUIRE(bytes.size() == 6 * channels * 4);
    size_t mismatches = 0;
    for (size_t p = 0; p < 6; ++p) {
      for (size_t c = 0; c < channels; ++c) {
        const uint8_t* b = &bytes[(p * channels + c) * 4];
        uint32_t bits = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
        uint32_t expected;
        std::memcpy(&expected, &frame.data[p * 4 + c], 4);
        if (bits != expected) ++mismatches;
      }
    }
    CHECK(mismatches == 0);
  }
  CHECK(render::rawChannels(render::Target::Depth).size() == 1);
  const size_t depthChannels = render::rawChannels(render::Target::Depth).size();
  CHECK(encode::packRaw(frame.width, frame.height, frame.data, depthChannels).size() == 6 * 4);
  // Pixel (0,0) depth, then (1,0): -1.5 and -0.5 as little-endian floats.
  std::vector<uint8_t> depth = encode::packRaw(frame.width, frame.height, frame.data, depthChannels);
  float first, second;
  std::memcpy(&first, &depth[0], 4);
  std::memcpy(&second, &depth[4], 4);
  CHECK(first == -1.5f);
  CHECK(second == -0.5f);
}

TEST_CASE("raw packing refuses a frame without float data") {
  render::Frame frame;
  frame.width = 4;
  frame.height = 4;
  frame.rgba.resize(64);
  CHECK_THROWS_AS(encode::packRaw(frame.width, frame.height, frame.data,
                                  render::rawChannels(render::Target::Final).size()),
                  std::invalid_argument);
}

TEST_CASE("a large JPEG encoded in strips decodes to exactly the pixels of one encoding") {
  // Frames of 1280x720 and up may be encoded in strips on several threads and joined with restart
  // markers; the decoded pixels must be those of tjCompress2 over the whole image. Sizes that
  // are not whole MCUs, both subsamplings (4:2:0 below quality 90, 4:4:4 from 90).
  for (auto [w, h, quality] : {std::tuple{1920u, 1080u, 80}, std::tuple{1283u, 731u, 75},
                               std::tuple{1301u, 997u, 95}}) {
    CAPTURE(w);
    CAPTURE(h);
    CAPTURE(quality);
    std::vector<uint8_t> source = testImage(w, h);
    // Detail that differs from strip to strip, so a misplaced strip would show.
    for (size_t i = 0; i < source.size(); i += 4) source[i] ^= uint8_t((i / 4 / w) * 7 + (i / 4) % 13);
    // 4 threads whatever the machine (by default a 2-core one encodes on one).
    const std::vector<uint8_t> strips = encode::encodeJpeg(source, w, h, quality, 4);

    std::unique_ptr<void, int (*)(void*)> handle(tjInitCompress(), tjDestroy);
    unsigned char* out = nullptr;
    unsigned long size = 0;
    REQUIRE(tjCompress2(handle.get(), source.data(), int(w), 0, int(h), TJPF_RGBA, &out, &size,
                        quality >= 90 ? TJSAMP_444 : TJSAMP_420, quality, 0) == 0);
    const std::vector<uint8_t> whole(out, out + size);
    tjFree(out);

    // Several strips: restart markers are present.
    bool restarts = false;
    for (size_t i = 0; i + 1 < strips.size(); ++i) {
      if (strips[i] == 0xFF && strips[i + 1] == 0xDD) restarts = true;
    }
    MESSAGE(w << "x" << h << " q" << quality << ": " << strips.size() << " bytes in strips, "
              << whole.size() << " in one");
    CHECK(restarts);
    const Decoded a = decodeJpeg(strips);
    const Decoded b = decodeJpeg(whole);
    CHECK(a.width == int(w));
    CHECK(a.height == int(h));
    CHECK(a.rgba == b.rgba);
    // Restart markers cost a few bytes each, and each strip pads its last byte.
    CHECK(strips.size() <= whole.size() + 64 * 8);
  }
}

TEST_CASE("JPEG from YCbCr 4:2:0 planes: strips decode to one encoding's pixels; bad planes named") {
  // Planes as the GPU lays them out (render::yuv420Layout): strides rounded up to 8 and 4, rows
  // to 2; an odd size, so the last strip and the padding are exercised.
  const uint32_t w = 1283, h = 731, yStride = 1288, chromaStride = 644, rows = 732;
  std::vector<uint8_t> y(size_t(yStride) * rows), cb(size_t(chromaStride) * rows / 2),
      cr(size_t(chromaStride) * rows / 2);
  for (size_t i = 0; i < y.size(); ++i) y[i] = uint8_t((i * 7 + i / yStride * 3) % 251);
  for (size_t i = 0; i < cb.size(); ++i) cb[i] = uint8_t(96 + (i * 5) % 64);
  for (size_t i = 0; i < cr.size(); ++i) cr[i] = uint8_t(112 + (i / chromaStride) % 48);
  const std::vector<uint8_t> strips = encode::encodeJpegYuv420(y, cb, cr, w, h, yStride, chromaStride, 80, 4);
  const std::vector<uint8_t> one = encode::encodeJpegYuv420(y, cb, cr, w, h, yStride, chromaStride, 80, 1);
  bool restarts = false;
  for (size_t i = 0; i + 1 < strips.size(); ++i) {
    if (strips[i] == 0xFF && strips[i + 1] == 0xDD) restarts = true;
  }
  CHECK(restarts);
  const Decoded a = decodeJpeg(strips);
  const Decoded b = decodeJpeg(one);
  CHECK(a.width == int(w));
  CHECK(a.height == int(h));
  CHECK(a.rgba == b.rgba);

  auto rejects = [&](std::span<const uint8_t> py, uint32_t width, uint32_t height, uint32_t ys,
                     int quality, const std::string& mentions) {
    try {
      encode::encodeJpegYuv420(py, cb, cr, width, height, ys, chromaStride, quality);
      FAIL("accepted");
    } catch (const std::invalid_argument& e) {
      CHECK(std::string(e.what()).find(mentions) != std::string::npos);
    }
  };
  rejects(std::span<const uint8_t>(y).subspan(0, 1000), w, h, yStride, 80, "planes of 1000");
  rejects(y, w, h, 1000, 80, "strides 1000");
  rejects(y, 0, h, yStride, 80, "JPEG size 0x731");
  rejects(y, w, h, yStride, 0, "JPEG quality 0");
}

namespace {

// A picture with what rendered frames have (gradients, hard edges, noise), `alpha` everywhere.
std::vector<uint8_t> pngTestPicture(uint32_t w, uint32_t h, uint8_t alpha) {
  std::vector<uint8_t> rgba(size_t(w) * h * 4);
  uint32_t noise = 12345;
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      noise = noise * 1664525u + 1013904223u;
      uint8_t* p = &rgba[(size_t(y) * w + x) * 4];
      p[0] = uint8_t(x * 255 / std::max(1u, w - 1));
      p[1] = uint8_t((x / 7 + y / 5) % 2 ? 200 : 30);
      p[2] = uint8_t(noise >> 24);
      p[3] = alpha;
    }
  }
  return rgba;
}

}  // namespace

TEST_CASE("PNG writer: every filter, level and thread count decodes to the same pixels") {
  using myriad::encode::PngFilter;
  for (auto [w, h] : {std::pair{1u, 1u}, std::pair{7u, 3u}, std::pair{1280u, 720u}}) {
    for (uint8_t alpha : {uint8_t(255), uint8_t(128)}) {
      const std::vector<uint8_t> rgba = pngTestPicture(w, h, alpha);
      for (PngFilter filter : {PngFilter::None, PngFilter::Sub, PngFilter::Up, PngFilter::Average,
                               PngFilter::Paeth}) {
        for (int level : {0, 1, 6}) {
          for (unsigned threads : {1u, 4u}) {
            CAPTURE(w);
            CAPTURE(int(alpha));
            CAPTURE(int(filter));
            CAPTURE(level);
            CAPTURE(threads);
            const std::vector<uint8_t> png = myriad::encode::writePng(
                w, h, myriad::encode::PngPixels::Rgba8, rgba, {level, filter, threads});
            // Opaque pictures are written as RGB (colour type 2), others as RGBA (6).
            CHECK(png[25] == (alpha == 255 ? 2 : 6));
            const myriad::encode::DecodedImage decoded = myriad::encode::decodePng(png);
            CHECK(decoded.width == w);
            CHECK(decoded.height == h);
            CHECK(decoded.rgba == rgba);
          }
        }
      }
    }
  }
}

TEST_CASE("PNG writer: 16-bit grey keeps every value and its text; bad sizes are refused") {
  const uint32_t w = 300, h = 257;
  std::vector<uint16_t> values(size_t(w) * h);
  for (size_t i = 0; i < values.size(); ++i) values[i] = uint16_t(i * 2654435761u >> 7);
  values[0] = 0;
  values[1] = 65535;
  for (unsigned threads : {1u, 3u}) {
    myriad::encode::PngSettings settings{1, myriad::encode::PngFilter::Paeth, threads};
    const std::vector<uint8_t> png = myriad::encode::writePng(
        w, h, myriad::encode::PngPixels::Grey16,
        {reinterpret_cast<const uint8_t*>(values.data()), values.size() * 2}, settings,
        {{"DepthScale", "0.001 m per unit"}});
    uint32_t dw = 0, dh = 0;
    myriad::encode::PngText text;
    CHECK(myriad::encode::decodePngGrey16(png, dw, dh, &text) == values);
    CHECK(dw == w);
    CHECK(dh == h);
    REQUIRE(text.size() == 1);
    CHECK(text[0].first == "DepthScale");
    CHECK(text[0].second == "0.001 m per unit");
  }
  for (myriad::encode::PngCompression c : myriad::encode::kPngCompressions) {
    const std::vector<uint8_t> rgba = pngTestPicture(64, 48, 255);
    CHECK(myriad::encode::decodePng(myriad::encode::encodePng(64, 48, rgba, c)).rgba == rgba);
    CHECK(myriad::encode::parsePngCompression(myriad::encode::pngCompressionName(c)) == c);
  }
  CHECK_FALSE(myriad::encode::parsePngCompression("99"));
  const std::vector<uint8_t> few(10);
  CHECK_THROWS_AS(myriad::encode::writePng(4, 4, myriad::encode::PngPixels::Rgba8, few, {}),
                  std::invalid_argument);
  CHECK_THROWS_AS(myriad::encode::writePng(0, 4, myriad::encode::PngPixels::Rgba8, {}, {}),
                  std::invalid_argument);
  // libdeflate's levels end at 12.
  CHECK_THROWS_AS(myriad::encode::writePng(1, 1, myriad::encode::PngPixels::Rgba8,
                                           std::span<const uint8_t>(few.data(), 4),
                                           {13, myriad::encode::PngFilter::Sub, 1}),
                  std::invalid_argument);
}
