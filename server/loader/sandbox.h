// The loader child's file-system and network sandbox (Landlock), on top of its rlimits: once
// entered, the process can open nothing but what it is given (for a library model, files under
// the model's directory; for an upload, nothing at all) and can make or accept no TCP connection.
#pragma once

#include <filesystem>
#include <string>

namespace myriad::loader {

// The Landlock ABI version the kernel offers, 0 where it has none (an older kernel, or Landlock
// not among the active security modules).
int landlockAbi();

// Restricts this process, for good. `readable` empty: no file may be opened; otherwise files and
// directories at or below it may be opened for reading (if `readable` cannot be opened, nothing
// is: it fails closed). Returns "" when all of it is in force, otherwise what went wrong (without
// Landlock in the kernel: nothing is restricted, and the child relies on its rlimits and on the
// scene loader's confined Assimp I/O).
std::string enterSandbox(const std::filesystem::path& readable);

}  // namespace myriad::loader
