// main() of the in-process GPU suites: doctest's, plus repeatable `--tune key=value` flags
// (render/tuning.h) that every suite's renderer is made with (createGpuSuite), so a CTest can run
// the same cases with another knob, as the server and the benches take it.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cstdio>
#include <string_view>
#include <vector>

#include "gpu_test_support.h"

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--tune" || arg.starts_with("--tune=")) {
      const char* value = arg == "--tune" ? (i + 1 < argc ? argv[++i] : "") : argv[i] + 7;
      try {
        myriad::render::applyTune(myriad::test::suiteTuning(), value);
      } catch (const myriad::render::TuningError& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
      }
      continue;
    }
    rest.push_back(argv[i]);
  }
  doctest::Context context(int(rest.size()), rest.data());
  return context.run();
}
