// Untrusted model files are parsed in a child process: this very executable, re-executed with
// --myriad-loader-child, under CPU, memory, file and time limits. Whatever Assimp does with a
// hostile file (crash, hang, unbounded allocation), the caller gets a ModelRejected with a reason
// and the server's own address space is untouched. Safe to call from several threads at once.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "loader/archive.h"
#include "scene/environment_map.h"
#include "scene/model_loader.h"
#include "scene/scene.h"

namespace myriad::loader {

// Faults the child can be told to commit, so that tests prove each failure path end to end. Set
// only from C++ (never from a request); production code leaves it at none.
enum class InjectedFault : uint8_t {
  none,
  crash,     // SIGSEGV
  hang,      // sleeps forever, using no CPU: only the wall-clock limit stops it
  spin,      // busy loop: the CPU limit stops it
  allocate,  // allocates and touches memory without bound: the memory limit stops it
  probeFiles,  // in the sandbox, tries to open the model's own file and /etc/passwd, and reports
               // the outcomes as a "parse" rejection: "own file: opened; /etc/passwd: Permission
               // denied" (own file: "none" for an upload)
};

struct LoadLimits {
  uint32_t cpuSeconds = 20;                  // RLIMIT_CPU of the child
  uint32_t wallSeconds = 30;                 // the parent kills the child after this
  uint64_t memoryBytes = 2ull << 30;         // RLIMIT_AS of the child
  uint64_t maxOutputBytes = 512ull << 20;    // the serialized scene the child may send back
  ArchiveLimits archive;                     // uploads of several files (zip or multipart)
  InjectedFault fault = InjectedFault::none; // tests only
};

// Why a model was not loaded. what() is one sentence for a 422 problem's `detail`. A kind of
// scene::ModelLoadError (itself a std::runtime_error), so code written against the in-process
// loader catches it unchanged.
struct ModelRejected : scene::ModelLoadError {
  // About the file: "parse", "crash", "timeout", "memory", "empty", "too-large", "unsupported".
  // About the server, not the file (a 503 rather than a 422): "busy" (maxConcurrentLoads()
  // children were running for the whole wall-clock limit), "internal" (no child could be started).
  std::string reason;

  ModelRejected(std::string reasonName, const std::string& sentence)
      : scene::ModelLoadError(sentence, kindOf(reasonName)), reason(std::move(reasonName)) {}

 private:
  static Kind kindOf(const std::string& reason) {
    return reason == "empty" ? Kind::empty : reason == "unsupported" ? Kind::unsupported : Kind::parse;
  }
};

// Parses an uploaded file. `filename`'s extension is the format hint (".glb", ".obj", ...); only
// the bytes given are read, so a .gltf naming external files is rejected ("unsupported").
scene::Scene loadModelBytes(std::string_view bytes, std::string_view filename,
                            const LoadLimits& limits = {});

// Parses a zip archive holding a model and the files it refers to (a .gltf with its .bin and
// images, an .obj with its .mtl). `entry` is the model's path inside (empty: the archive's one
// model file). The archive is read in the child, under `limits.archive` (archive.h); a refusal
// there is "too-large" (a limit, named) or "unsupported"/"parse" (the archive's fault).
scene::Scene loadModelArchive(std::string_view zipBytes, std::string_view filename,
                              std::string_view entry, const LoadLimits& limits = {});

// The same for several uploaded files (a multipart/form-data upload) by member path.
scene::Scene loadModelFiles(const scene::MemoryFiles& files, std::string_view entry,
                            const LoadLimits& limits = {});

// Parses a file on disk (a library model). The child opens it, so a .gltf may use the .bin and
// images beside it (but nothing outside the file's directory).
scene::Scene loadModelFile(const std::filesystem::path& path, const LoadLimits& limits = {});

// An equirectangular Radiance .hdr for the environment light, decoded and resampled to the
// environment size (scene/environment_map.h) in the child, under the same limits as a model plus
// loader/hdr_decode.h's (dimensions checked from the header before decoding). A refusal is a
// ModelRejected naming the problem: "empty", "parse" (not a Radiance file, a bad header, a
// truncated file), "too-large" (dimensions), or the child's crash/timeout/memory.
scene::EnvironmentImage loadEnvironmentBytes(std::string_view bytes, std::string_view filename,
                                             const LoadLimits& limits = {});
// A library .hdr: the child opens it (nothing outside its directory).
scene::EnvironmentImage loadEnvironmentFile(const std::filesystem::path& path,
                                            const LoadLimits& limits = {});
// Whether `filename` names a Radiance .hdr (by its extension, any case).
bool isEnvironmentFileName(std::string_view filename);

// How many loader children run at once, process-wide; more loads wait (up to their wallSeconds)
// for a turn. Each child may use LoadLimits::memoryBytes, so a burst of uploads must not multiply
// that by the number of HTTP workers. Between 2 and 8, by the number of CPUs.
unsigned maxConcurrentLoads();

// Whether loader children run inside a Landlock sandbox (see sandbox.h) on this kernel: they can
// then open no file but a library model's own directory, and make no TCP connection.
bool childrenSandboxed();

// Call first thing in main(). In the loader child it does the work and never returns (exits the
// process); otherwise it returns false at once.
bool runChildIfRequested(int argc, char** argv);

// The flag that marks a loader child on the command line.
inline constexpr std::string_view kChildFlag = "--myriad-loader-child";

}  // namespace myriad::loader
