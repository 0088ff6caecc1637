// Not a harness: writes the scene wire seeds of the scene_wire harness. For each model file
// given, loads it as the loader child does (scene::loadModel) and writes encodeScene's bytes to
// OUT_DIR/<n>-<file name>.wire; models that do not load are skipped with a line on stderr.
// Usage: fuzz_wire_seeds OUT_DIR MODEL...
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "loader/scene_wire.h"
#include "scene/builtin_scene.h"
#include "scene/model_loader.h"

namespace fs = std::filesystem;
using namespace myriad;

namespace {

void write(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: fuzz_wire_seeds OUT_DIR MODEL...\n");
    return 2;
  }
  const fs::path out = argv[1];
  fs::create_directories(out);
  // The built-in scene with a few lights: a seed with lights and several meshes and materials.
  write(out / "0-builtin.wire", loader::encodeScene(scene::makeBuiltinScene(8, 1)));
  int written = 1;
  for (int i = 2; i < argc; ++i) {
    const fs::path model = argv[i];
    try {
      const std::string wire = loader::encodeScene(scene::loadModel(model));
      write(out / (std::to_string(i - 1) + "-" + model.filename().string() + ".wire"), wire);
      ++written;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz_wire_seeds: skipped %s: %s\n", model.c_str(), e.what());
    }
  }
  std::printf("fuzz_wire_seeds: %d seeds in %s\n", written, out.c_str());
  return 0;
}
