// myriad-png-bench: what a lossless PNG of a real rendered frame costs with each encoder Debian
// offers (libpng at zlib levels and filters, libspng, libdeflate through encode/png_writer), and
// how large it is; every output is decoded again and checked against the frame's pixels. The
// numbers behind encode/png.cpp's choice (docs/performance.md "PNG encoding").
//
//   myriad-png-bench [--width 1920] [--height 1080] [--reps 7] [--device NAME] [--json FILE]
//                    [--only ENCODER]   (libpng, libspng, libdeflate, server: rows whose encoder
//                                        starts so)
//
// Renders the built-in scene's `final` view (256 lights, FXAA, markers: what GET /v1/frame
// returns) once, then encodes it --reps times per configuration on one thread; medians.
#include <png.h>
#include <spng.h>

#include <algorithm>
#include <chrono>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/png.h"
#include "encode/png_writer.h"
#include "gpu/context.h"
#include "render/renderer.h"
#include "scene/builtin_scene.h"

using namespace myriad;

namespace {

struct Sink {
  std::vector<uint8_t>* bytes;
};

void appendPng(png_structp png, png_bytep data, size_t length) {
  auto* sink = static_cast<Sink*>(png_get_io_ptr(png));
  sink->bytes->insert(sink->bytes->end(), data, data + length);
}
void flushNothing(png_structp) {}

// libpng as encode/png.cpp used it before (RGBA8, one filter set, a zlib level).
std::vector<uint8_t> libpngEncode(uint32_t w, uint32_t h, const std::vector<uint8_t>& rgba,
                                  int level, int filters) {
  std::vector<uint8_t> bytes;
  Sink sink{&bytes};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows(h);
  for (uint32_t y = 0; y < h; ++y) rows[y] = const_cast<png_bytep>(rgba.data() + size_t(w) * 4 * y);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng failed");
  }
  png_set_write_fn(png, &sink, appendPng, flushNothing);
  png_set_IHDR(png, info, w, h, 8, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, level);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, filters);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return bytes;
}

std::vector<uint8_t> spngEncode(uint32_t w, uint32_t h, const std::vector<uint8_t>& rgba, int level,
                                int filters) {
  spng_ctx* ctx = spng_ctx_new(SPNG_CTX_ENCODER);
  spng_set_option(ctx, SPNG_ENCODE_TO_BUFFER, 1);
  spng_set_option(ctx, SPNG_IMG_COMPRESSION_LEVEL, level);
  spng_set_option(ctx, SPNG_FILTER_CHOICE, filters);
  spng_ihdr ihdr{};
  ihdr.width = w;
  ihdr.height = h;
  ihdr.bit_depth = 8;
  ihdr.color_type = SPNG_COLOR_TYPE_TRUECOLOR_ALPHA;
  spng_set_ihdr(ctx, &ihdr);
  int err = spng_encode_image(ctx, rgba.data(), rgba.size(), SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE);
  if (err) {
    spng_ctx_free(ctx);
    throw std::runtime_error(std::string("spng: ") + spng_strerror(err));
  }
  size_t size = 0;
  void* data = spng_get_png_buffer(ctx, &size, &err);
  std::vector<uint8_t> out(static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  std::free(data);
  spng_ctx_free(ctx);
  return out;
}

struct Config {
  std::string encoder, filter;
  int level;
  std::function<std::vector<uint8_t>()> run;
};

}  // namespace

int main(int argc, char** argv) {
  uint32_t width = 1920, height = 1080;
  int reps = 7;
  std::string device, jsonPath, only;
  render::Tuning tuning;  // --tune key=value, repeatable (render/tuning.h)
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--width") width = uint32_t(std::stoul(value()));
    else if (arg == "--height") height = uint32_t(std::stoul(value()));
    else if (arg == "--reps") reps = std::max(1, std::stoi(value()));
    else if (arg == "--device") device = value();
    else if (arg == "--json") jsonPath = value();
    else if (arg == "--only") only = value();
    else if (arg == "--tune") {
      try {
        render::applyTune(tuning, value());
      } catch (const render::TuningError& e) {
        std::fprintf(stderr, "myriad-png-bench: %s\n", e.what());
        return 2;
      }
    } else {
      std::fprintf(stderr, "usage: myriad-png-bench [--width W] [--height H] [--reps N] "
                           "[--device NAME] [--json FILE] [--only ENCODER] "
                           "[--tune KEY=VALUE]...\n%s",
                   render::tuningKeys());
      return 2;
    }
  }

  std::vector<uint8_t> rgba;
  std::string deviceName;
  {
    auto context = gpu::createContext(
        {.validation = false, .device = device, .pipelineStatistics = tuning.pipelineStatistics});
    deviceName = context->info.name;
    render::Renderer renderer(*context, tuning);
    const scene::Scene scene = scene::makeBuiltinScene();
    const render::SceneId id = renderer.createScene(scene);
    render::FrameSettings settings;
    settings.takeLightingFrom(scene);
    settings.camera = scene.camera;
    settings.width = width;
    settings.height = height;
    settings.target = render::Target::Final;
    render::Frame frame = renderer.render(id, settings);
    rgba.assign(frame.pixels().begin(), frame.pixels().end());
  }

  std::vector<Config> configs;
  const std::pair<const char*, int> libpngFilters[] = {
      {"none", PNG_FILTER_NONE}, {"sub", PNG_FILTER_SUB}, {"up", PNG_FILTER_UP},
      {"paeth", PNG_FILTER_PAETH}, {"all", PNG_ALL_FILTERS}};
  for (int level : {1, 3, 6}) {
    for (auto [name, bits] : libpngFilters) {
      configs.push_back({"libpng", name, level, [&, level, bits = bits] {
                           return libpngEncode(width, height, rgba, level, bits);
                         }});
    }
  }
  const std::pair<const char*, int> spngFilters[] = {{"sub", SPNG_FILTER_CHOICE_SUB},
                                                     {"all", SPNG_FILTER_CHOICE_ALL}};
  for (int level : {1, 3, 6}) {
    for (auto [name, bits] : spngFilters) {
      configs.push_back({"libspng", name, level, [&, level, bits = bits] {
                           return spngEncode(width, height, rgba, level, bits);
                         }});
    }
  }
  const std::pair<const char*, encode::PngFilter> ourFilters[] = {
      {"none", encode::PngFilter::None}, {"sub", encode::PngFilter::Sub},
      {"up", encode::PngFilter::Up}, {"paeth", encode::PngFilter::Paeth}};
  for (int level : {0, 1, 2, 3, 6, 9}) {
    for (auto [name, filter] : ourFilters) {
      configs.push_back({"libdeflate", name, level, [&, level, filter = filter] {
                           return encode::writePng(width, height, encode::PngPixels::Rgba8, rgba,
                                                   {level, filter, 1});
                         }});
    }
  }
  // What the server sends for each ?compression= choice (encode/png.h): on one thread, and on
  // the threads the server uses on this machine (strips deflated by zlib in parallel; the same
  // as one thread on a machine of 2-3 cores).
  // `server-8`: strips on 8 threads whatever the machine has (the size a 16-core host's frames
  // have; its time only means something with 8 free cores).
  for (unsigned threads : {1u, 0u, 8u}) {
    for (encode::PngCompression c : encode::kPngCompressions) {
      configs.push_back({threads == 1 ? "server-1" : threads == 8 ? "server-8" : "server",
                         std::string(encode::pngCompressionName(c)),
                         encode::pngSettings(c).level, [&, c, threads] {
                           encode::PngSettings s = encode::pngSettings(c);
                           s.threads = threads;
                           return encode::writePng(width, height, encode::PngPixels::Rgba8, rgba, s);
                         }});
    }
  }

  std::printf("myriad-png-bench: %ux%u final frame of the built-in scene rendered on %s; "
              "%d encodes per configuration (one thread but `server`: %u hardware threads), "
              "medians and minima\n",
              width, height, deviceName.c_str(), reps, std::thread::hardware_concurrency());
  std::printf("%-10s %-8s %5s %10s %10s %10s %8s\n", "encoder", "filter", "level", "median ms",
              "min ms", "KB", "ratio");
  nlohmann::json results = nlohmann::json::array();
  for (const Config& config : configs) {
    if (!only.empty() && config.encoder.rfind(only, 0) != 0) continue;
    std::vector<double> times;
    std::vector<uint8_t> png;
    for (int r = 0; r < reps; ++r) {
      const auto start = std::chrono::steady_clock::now();
      png = config.run();
      times.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(times.begin(), times.end());
    const double median = times[times.size() / 2];
    const encode::DecodedImage decoded = encode::decodePng(png);
    if (decoded.width != width || decoded.height != height || decoded.rgba != rgba) {
      std::fprintf(stderr, "myriad-png-bench: %s %s level %d does not decode to the frame\n",
                   config.encoder.c_str(), config.filter.c_str(), config.level);
      return 1;
    }
    std::printf("%-10s %-8s %5d %10.1f %10.1f %10.0f %8.2f\n", config.encoder.c_str(),
                config.filter.c_str(), config.level, median, times.front(), png.size() / 1000.0,
                double(rgba.size()) / double(png.size()));
    std::fflush(stdout);
    results.push_back({{"encoder", config.encoder}, {"filter", config.filter},
                       {"level", config.level}, {"ms", median}, {"minMs", times.front()},
                       {"bytes", png.size()}});
  }
  if (!jsonPath.empty()) {
    std::ofstream out(jsonPath);
    out << nlohmann::json{{"width", width}, {"height", height}, {"device", deviceName},
                          {"reps", reps}, {"results", results}}
               .dump(2)
        << '\n';
  }
  return 0;
}
