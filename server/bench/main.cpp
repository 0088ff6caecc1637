// myriad-bench: GPU timings of the lighting techniques across light counts, for
// docs/performance.md. Performance is claimed only from this (GPU timestamps after warm-up,
// medians), never from a timed test.
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench/bench_scene.h"
#include "bench/measure.h"
#include "bench/options.h"
#include "bench/report.h"
#include "gpu/context.h"
#include "render/renderer.h"

using namespace myriad;

namespace {

std::string utcNow() {
  std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// Rewritten after every configuration so a run cut short still leaves what it measured.
void writeJson(const std::string& path, const bench::RunInfo& run,
               const std::vector<bench::ConfigResult>& results) {
  if (path.empty()) return;
  std::ofstream out(path, std::ios::trunc);
  out << bench::toJson(run, results).dump(2) << '\n';
  if (!out) throw std::runtime_error("could not write " + path + ".");
}

int run(const bench::Options& options, const std::string& commandLine) {
  auto context = gpu::createContext({.validation = options.validate,
                                     .device = options.device,
                                     .pipelineStatistics = options.tuning.pipelineStatistics});
  if (!context->info.timestampsSupported) {
    std::fprintf(stderr, "myriad-bench: %s has no timestamp queries on its queue; nothing to time.\n",
                 context->info.name.c_str());
    return 1;
  }
  render::Renderer renderer(*context, options.tuning);
  renderer.setGBufferPath(options.gbuffer);
  render::SceneId sceneId = 0;
  bench::RunInfo info;
  info.device = context->info;
  info.command = commandLine;
  info.startedUtc = utcNow();
  info.validation = options.validate;
  info.plan = options.plan;
  info.scene = std::string(bench::benchSceneName(options.scene));
  if (options.scene == bench::BenchScene::Model) {
    info.scene = std::filesystem::path(options.modelPath).filename().string() +
                 (options.textures ? "" : "-untextured");
  }
  info.lightsPerPoint = options.scene == bench::BenchScene::Floor ? options.lightsPerPoint : 0.0f;
  info.seed = options.seed;
  info.gbuffer = std::string(render::gbufferPathName(options.gbuffer));
  bench::printHeader(stdout, info);

  std::vector<bench::ConfigResult> results;
  for (uint32_t lights : options.lightCounts) {
    scene::Scene scene = bench::makeBenchScene(
        {.kind = options.scene, .lightCount = lights, .seed = options.seed,
         .lightsPerPoint = options.lightsPerPoint, .modelPath = options.modelPath,
         .textures = options.textures});
    bench::addShadowedLights(scene, options.plan.shadowedLights, options.plan.shadowedSpots);
    // One scene at a time: the previous one's memory goes before the next is uploaded.
    if (sceneId != 0) renderer.destroyScene(sceneId);
    sceneId = renderer.createScene(scene);
    for (render::Technique technique : options.techniques) {
      bench::ConfigResult result;
      if (technique == render::Technique::Volumes && lights > options.volumesMaxLights) {
        result.width = options.plan.width;
        result.height = options.plan.height;
        result.lights = lights;
        result.technique = technique;
        result.skipped = "more than --volumes-max-lights " + std::to_string(options.volumesMaxLights);
      } else {
        result = bench::measure(renderer, *context, sceneId, scene, technique, lights,
                                options.plan);
      }
      result.scene = info.scene;
      bench::printResult(stdout, result);
      results.push_back(std::move(result));
      info.validationMessages = context->validationMessages.load();
      writeJson(options.jsonPath, info, results);
    }
  }
  if (options.validate) {
    std::printf("validation messages: %u\n", info.validationMessages);
    if (info.validationMessages > 0) return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string commandLine = "myriad-bench";
  for (const std::string& a : args) commandLine += " " + a;
  try {
    bench::Options options = bench::parseOptions(args);
    if (options.help) {
      std::fputs(bench::kUsage, stdout);
      std::fputs(render::tuningKeys(), stdout);
      return 0;
    }
    return run(options, commandLine);
  } catch (const bench::UsageError& e) {
    std::fprintf(stderr, "myriad-bench: %s\n", e.what());
    return 2;
  } catch (const gpu::NoDeviceError& e) {
    std::fprintf(stderr, "myriad-bench: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-bench: %s\n", e.what());
    return 1;
  }
}
