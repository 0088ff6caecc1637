#include "bench/options.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace myriad::bench {

namespace {

// Past this the light buffers outgrow what some devices bind (lavapipe: 128 MiB per buffer).
constexpr uint64_t kMaxLights = 1u << 22;
constexpr uint64_t kMaxDimension = 16384;
constexpr uint64_t kMaxFrames = 100000;

uint64_t parseCount(const std::string& flag, std::string_view text, uint64_t min, uint64_t max) {
  uint64_t value = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || value < min || value > max) {
    throw UsageError(flag + " expects an integer from " + std::to_string(min) + " to " +
                     std::to_string(max) + ", not \"" + std::string(text) + "\".");
  }
  return value;
}

double parsePositive(const std::string& flag, std::string_view text) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(value) || value <= 0.0) {
    throw UsageError(flag + " expects a positive number, not \"" + std::string(text) + "\".");
  }
  return value;
}

std::vector<std::string_view> splitList(const std::string& flag, std::string_view text) {
  std::vector<std::string_view> items;
  size_t start = 0;
  while (start <= text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string_view::npos) comma = text.size();
    std::string_view item = text.substr(start, comma - start);
    if (item.empty()) throw UsageError(flag + " expects a comma-separated list without empty items.");
    items.push_back(item);
    start = comma + 1;
  }
  return items;
}

}  // namespace

const char* const kUsage =
    "usage: myriad-bench [--width N] [--height N] [--lights N,N,...] [--techniques T,T,...]\n"
    "                    [--frames N] [--warmup N] [--scene floor|builtin] [--lights-per-point F]\n"
    "                    [--seed N] [--max-seconds S] [--volumes-max-lights N] [--markers]\n"
    "                    [--json PATH] [--validate] [--device INDEX|NAME]\n"
    "                    [--environment none|sky] [--environment-every-frame]\n"
    "                    [--antialias none|fxaa|taa|ssaa]\n"
    "                    [--sun-shadows 256|512|1024|2048|4096 [--sun-cascades 1-4]]\n"
    "                    [--camera still|orbit]\n"
    "                    [--shadowed-lights N [--shadowed-kind point|spot]]\n"
    "                    [--local-shadows none|maps|stochastic]\n"
    "                    [--model PATH [--textures on|off]] [--gbuffer raster|compute|auto]\n"
    "                    [--tune KEY=VALUE]...\n"
    "Renders animated frames for every light count x technique, timing each pass with GPU\n"
    "timestamp queries after warm-up, and prints medians and 90th percentiles.\n"
    "defaults: 1920x1080, lights 1000,10000,100000,1000000, every technique,\n"
    "          50 frames after 10 warm-up, scene floor with 64 lights per point, volumes only up to\n"
    "          100000 lights, at most 30 s of timed frames per configuration, markers off,\n"
    "          antialias fxaa (the final image's \"antialias\" pass; the server's default too;\n"
    "          taa: 8 jittered sub-frames a frame, ssaa: one at 2x2 the size, each resolved on\n"
    "          the host, timed as \"resolve-taa\" or \"resolve-ssaa\", the GPU passes summed;\n"
    "          taa-stream: a stream's taa, one jittered frame a frame resolved against its history\n"
    "          on the GPU, timed as \"taa\").\n"
    "--validate enables VK_LAYER_KHRONOS_validation; any message makes the exit status 1.\n"
    "--gbuffer compute makes the G-buffer with compute shaders where the scene qualifies (opaque,\n"
    "untextured materials; 64-bit atomics), timed as \"visibility\" and \"resolve\" instead of\n"
    "\"gbuffer\" (default raster, comparable with earlier runs; auto, the server's default: compute\n"
    "where it qualifies, except on CPU devices).\n"
    "--environment sky lights every frame with the procedural sky (default none: the constant\n"
    "ambient); with --environment-every-frame its maps are rebuilt every frame, timed as the\n"
    "\"environment\" pass.\n"
    "--sun-shadows N renders the sun's shadow map (N texels across) every frame, timed as the\n"
    "\"shadow\" pass (default: no shadows); --sun-cascades N (1-4, default 4, the server's) splits\n"
    "the view's depth between N maps of that size. --camera orbit turns the camera about the scene\n"
    "by 0.36 degrees a frame and keeps the sun (the maps follow the camera: scrolled or drawn; the\n"
    "report counts which), instead of a still camera under a sun that turns every other frame.\n"
    "--shadowed-lights N (0-16) adds N lights asking for shadows over the scene (besides --lights),\n"
    "every one given a map each frame, timed as the \"light-shadows\" pass; --shadowed-kind spot\n"
    "makes them spots (one tile each) instead of point lights (six tiles, a cube).\n"
    "--local-shadows stochastic shadows every local light (clustered technique only): a BVH of the\n"
    "scene built in compute (\"bvh-build\" / \"bvh-refit\"; every frame with --tune\n"
    "bvh-update=rebuild or refit, else once) and one shadow ray a pixel (\"shadow-rays\"); the\n"
    "report adds the rays a frame and rays/s (default maps: as --shadowed-lights says). With\n"
    "--sun-shadows the sun is traced too (a ray a lit pixel more, not counted; no \"shadow\" pass).\n"
    "--model PATH renders a model file (loaded in this process) from its framing camera, with\n"
    "lights around it; --textures off strips its textures (the same geometry, factors only).\n"
    "--tune KEY=VALUE (repeatable) sets one of the renderer's knobs (render/tuning.h), as on\n"
    "myriad-server; the run's \"command\" records it. Keys:\n";

Options parseOptions(const std::vector<std::string>& args) {
  Options o;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    auto value = [&]() -> std::string_view {
      if (i + 1 >= args.size()) throw UsageError(flag + " expects a value.");
      return args[++i];
    };
    if (flag == "--help" || flag == "-h") {
      o.help = true;
    } else if (flag == "--width") {
      o.plan.width = uint32_t(parseCount(flag, value(), 1, kMaxDimension));
    } else if (flag == "--height") {
      o.plan.height = uint32_t(parseCount(flag, value(), 1, kMaxDimension));
    } else if (flag == "--lights") {
      o.lightCounts.clear();
      for (auto item : splitList(flag, value())) o.lightCounts.push_back(uint32_t(parseCount(flag, item, 0, kMaxLights)));
    } else if (flag == "--techniques") {
      o.techniques.clear();
      for (auto item : splitList(flag, value())) {
        auto technique = render::parseTechnique(item);
        if (!technique) {
          throw UsageError("--techniques expects " + render::techniqueChoices() + ", not \"" +
                           std::string(item) + "\".");
        }
        o.techniques.push_back(*technique);
      }
    } else if (flag == "--frames") {
      o.plan.timedFrames = uint32_t(parseCount(flag, value(), 1, kMaxFrames));
    } else if (flag == "--warmup") {
      o.plan.warmupFrames = uint32_t(parseCount(flag, value(), 0, kMaxFrames));
    } else if (flag == "--scene") {
      std::string_view name = value();
      auto scene = parseBenchScene(name);
      if (!scene) throw UsageError("--scene expects floor or builtin, not \"" + std::string(name) + "\".");
      o.scene = *scene;
    } else if (flag == "--model") {
      o.modelPath = std::string(value());
      o.scene = BenchScene::Model;
    } else if (flag == "--textures") {
      std::string_view onOff = value();
      if (onOff != "on" && onOff != "off") {
        throw UsageError("--textures expects on or off, not \"" + std::string(onOff) + "\".");
      }
      o.textures = onOff == "on";
    } else if (flag == "--lights-per-point") {
      o.lightsPerPoint = float(parsePositive(flag, value()));
    } else if (flag == "--seed") {
      o.seed = parseCount(flag, value(), 0, UINT64_MAX);
    } else if (flag == "--max-seconds") {
      o.plan.maxSecondsPerConfig = parsePositive(flag, value());
    } else if (flag == "--volumes-max-lights") {
      o.volumesMaxLights = uint32_t(parseCount(flag, value(), 0, kMaxLights));
    } else if (flag == "--environment") {
      std::string_view name = value();
      auto mode = render::parseEnvironmentMode(name);
      if (!mode || *mode == render::EnvironmentMode::Hdr) {
        throw UsageError("--environment expects none or sky, not \"" + std::string(name) + "\".");
      }
      o.plan.environment = *mode;
    } else if (flag == "--environment-every-frame") {
      o.plan.environmentEveryFrame = true;
    } else if (flag == "--sun-shadows") {
      std::string_view text = value();
      const uint64_t size = parseCount(flag, text, 0, UINT32_MAX);
      if (std::find(render::kShadowMapSizes.begin(), render::kShadowMapSizes.end(), size) ==
          render::kShadowMapSizes.end()) {
        throw UsageError("--sun-shadows expects 256, 512, 1024, 2048 or 4096, not \"" +
                         std::string(text) + "\".");
      }
      o.plan.sunShadowMap = uint32_t(size);
    } else if (flag == "--camera") {
      const std::string_view mode = value();
      if (mode != "still" && mode != "orbit") {
        throw UsageError("--camera expects still or orbit, not \"" + std::string(mode) + "\".");
      }
      o.plan.orbitCamera = mode == "orbit";
    } else if (flag == "--sun-cascades") {
      o.plan.sunCascades = uint32_t(parseCount(flag, value(), 1, render::kMaxSunCascades));
    } else if (flag == "--shadowed-lights") {
      o.plan.shadowedLights = uint32_t(parseCount(flag, value(), 0, render::kMaxShadowedLights));
    } else if (flag == "--shadowed-kind") {
      std::string_view kind = value();
      if (kind != "point" && kind != "spot") {
        throw UsageError("--shadowed-kind expects point or spot, not \"" + std::string(kind) + "\".");
      }
      o.plan.shadowedSpots = kind == "spot";
    } else if (flag == "--local-shadows") {
      std::string_view name = value();
      const std::optional<render::LocalShadows> mode = render::parseLocalShadows(name);
      if (!mode) {
        throw UsageError("--local-shadows expects none, maps or stochastic, not \"" +
                         std::string(name) + "\".");
      }
      o.plan.localShadows = *mode;
    } else if (flag == "--markers") {
      o.plan.markers = true;
    } else if (flag == "--antialias") {
      std::string_view name = value();
      // taa-stream: a stream's taa (one jittered frame resolved against a history), not a still's.
      o.plan.streamHistory = name == "taa-stream";
      auto mode = render::parseAntialias(o.plan.streamHistory ? "taa" : name);
      if (!mode) throw UsageError("--antialias expects none, fxaa, taa, taa-stream or ssaa, not \"" + std::string(name) + "\".");
      o.plan.antialias = *mode;
    } else if (flag == "--json") {
      std::string_view path = value();
      if (path.empty()) throw UsageError("--json expects a file path.");
      o.jsonPath = path;
    } else if (flag == "--gbuffer") {
      std::string_view name = value();
      auto path = render::parseGBufferPath(name);
      if (!path) {
        throw UsageError("--gbuffer expects raster, compute or auto, not \"" + std::string(name) + "\".");
      }
      o.gbuffer = *path;
    } else if (flag == "--tune") {
      try {
        render::applyTune(o.tuning, value());
      } catch (const render::TuningError& e) {
        throw UsageError(e.what());
      }
    } else if (flag == "--validate") {
      o.validate = true;
    } else if (flag == "--device") {
      std::string_view device = value();
      if (device.empty()) throw UsageError("--device expects a device index or name.");
      o.device = device;
    } else {
      throw UsageError("unknown flag \"" + flag + "\" (see --help).");
    }
  }
  return o;
}

}  // namespace myriad::bench
