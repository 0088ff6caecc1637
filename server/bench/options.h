// myriad-bench's command line.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/bench_scene.h"
#include "bench/measure.h"
#include "render/frame.h"
#include "render/tuning.h"

namespace myriad::bench {

// A bad flag or value; the message is one sentence naming it.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Options {
  Plan plan;
  BenchScene scene = BenchScene::Floor;
  std::vector<uint32_t> lightCounts{1000, 10000, 100000, 1000000};
  std::vector<render::Technique> techniques = render::allTechniques();
  // Light volumes rasterise a proxy per light; past this many they take seconds a frame on GPUs
  // with few graphics units, so larger counts are skipped (and say so) unless asked for.
  uint32_t volumesMaxLights = 100000;
  float lightsPerPoint = 64.0f;
  std::string modelPath;  // --model: BenchScene::Model
  bool textures = true;   // --textures on|off (Model)
  uint64_t seed = 1;
  std::string jsonPath;
  bool validate = false;
  std::string device;
  render::GBufferPath gbuffer = render::GBufferPath::Raster;  // --gbuffer
  render::Tuning tuning;  // --tune key=value, repeatable (render/tuning.h)
  bool help = false;
};

Options parseOptions(const std::vector<std::string>& args);

extern const char* const kUsage;

}  // namespace myriad::bench
