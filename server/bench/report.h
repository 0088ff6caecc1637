// What the benchmark prints (a table per configuration, for people) and writes (JSON, for
// docs/performance.md and later comparison).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/measure.h"
#include "gpu/device_info.h"

namespace myriad::bench {

struct RunInfo {
  gpu::DeviceInfo device;
  std::string command;  // the command line, as run
  std::string startedUtc;
  bool validation = false;
  uint32_t validationMessages = 0;
  Plan plan;
  std::string scene;
  float lightsPerPoint = 0.0f;
  uint64_t seed = 0;
  std::string gbuffer = "raster";  // --gbuffer (which path each frame took: its pass names)
};

void printHeader(std::FILE* out, const RunInfo& run);
// One line per configuration, then its passes indented under it.
void printResult(std::FILE* out, const ConfigResult& result);

nlohmann::json toJson(const RunInfo& run, const std::vector<ConfigResult>& results);

}  // namespace myriad::bench
