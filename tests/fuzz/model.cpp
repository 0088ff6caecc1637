// The loader child's whole model path, in-process: scene::loadModelFromMemory (Assimp's import,
// validation and our post-processing, exactly as child.cpp calls it on an upload), then
// encodeScene and the parent's decodeScene of the result.
//
// Input: the first byte picks the file extension (kExtensions, modulo), the rest is the file. The
// extension "zip" takes the child's archive path instead: readZipArchive, modelEntryOf (the one
// model of the archive) and loadModelFromFiles (the model reads its .bin, .mtl and images from
// the archive's members).
// Promises checked: the load ends in a scene or a ModelLoadError (the child turns any other
// std::exception into a "parse" rejection too, so those are tolerated but not expected); a
// scene the child would send is one the parent accepts (decodeScene does not refuse it).
//
// Assimp is Debian's uninstrumented build: libFuzzer's coverage sees our code and not Assimp's
// branches, and AddressSanitizer sees Assimp's heap calls (malloc, free, memcpy and friends) but
// not its plain loads and stores. A crash inside Assimp is what the child process exists to
// contain (a 422 "crash"); here it stops the run, so that it is seen.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>

#include "fuzz_support.h"
#include "loader/archive.h"
#include "loader/scene_wire.h"
#include "scene/model_loader.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;
using myriad::fuzz::broken;

namespace {

// The upload formats the corpus has seeds for (tests/fuzz/make_corpus.py keeps the same order):
// the documented ones first (OBJ, glTF 2 embedded and binary, PLY, STL), then other common
// formats Assimp reads. Appending is safe; reordering invalidates kept corpora.
constexpr std::string_view kExtensions[] = {"obj", "gltf", "glb", "ply", "stl", "off",
                                            "dae", "fbx",  "3ds", "x",   "ac",  "ase",
                                            "ms3d", "md2", "nff", "smd", "zip"};
constexpr size_t kExtensionCount = sizeof kExtensions / sizeof kExtensions[0];

}  // namespace

// Assimp leaks on some error paths (an importer's ReadFile that throws). The loader child exits
// after every load, so in the server such a leak lives for one load; here, where a million loads
// share one process, LeakSanitizer would stop the run on the first. Leaks with an Assimp frame on
// their stack are therefore suppressed; a leak whose stack has none is still reported. So are zlib
// stream states (inflateInit2_) that Assimp's FBX reader leaves when it throws: Assimp and zlib
// are built without frame pointers, so those stacks end in zlib and never show the Assimp frame.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libassimp.so\nleak:inflateInit2_\n";
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string filename = "upload." + std::string(kExtensions[data[0] % kExtensionCount]);
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  std::string wire;
  try {
    if (filename.ends_with(".zip")) {
      // Smaller than the server's archive limits, so one input cannot hold 512 MiB for the run.
      const scene::MemoryFiles files =
          loader::readZipArchive(bytes, filename, loader::ArchiveLimits{64, 64u << 20, 200});
      wire = loader::encodeScene(
          scene::loadModelFromFiles(files, scene::modelEntryOf(files, "", filename)));
    } else {
      wire = loader::encodeScene(scene::loadModelFromMemory(bytes, filename));
    }
  } catch (const scene::ModelLoadError&) {
    return 0;
  } catch (const std::bad_alloc&) {
    return 0;  // the child exits with kExitOutOfMemory: a "memory" rejection
  } catch (const std::exception&) {
    return 0;  // the child's catch-all: a "parse" rejection
  }
  try {
    (void)loader::decodeScene(wire);
  } catch (const loader::SceneWireError& e) {
    broken(std::string("the parent refuses the scene the child wrote: ") + e.what());
  }
  return 0;
}
