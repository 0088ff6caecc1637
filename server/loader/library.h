// The server-side model library: the files under `--models DIR` that a session may load by name.
// Names are relative to DIR with '/' separators; resolve() is the only way from a name to a path,
// and it refuses anything that would leave DIR.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace myriad::loader {

struct LibraryEntry {
  std::string name;  // relative to the library root, '/'-separated
  uint64_t bytes = 0;
};

class ModelLibrary {
 public:
  // An empty `root` is a library with no models. A root that does not exist or is not a
  // directory throws std::runtime_error with one sentence (a start-up error).
  explicit ModelLibrary(const std::filesystem::path& root);

  // Regular, non-hidden files with an extension Assimp reads, recursively, sorted by name.
  // Reads the directory each time, so files added while serving appear.
  std::vector<LibraryEntry> list() const;

  // The file `name` refers to, or nullopt when it is not a library model: empty, absolute, any
  // ".." or "." or hidden component, a backslash or NUL, not a regular file, an extension Assimp
  // does not read, or a path (after following symlinks) outside the root.
  std::optional<std::filesystem::path> resolve(std::string_view name) const;
  // The same for an environment image: a Radiance .hdr under the root (not listed by list()).
  std::optional<std::filesystem::path> resolveEnvironment(std::string_view name) const;

  const std::filesystem::path& root() const { return root_; }
  bool empty() const { return root_.empty(); }

 private:
  std::optional<std::filesystem::path> resolveFile(std::string_view name, bool environment) const;
  std::filesystem::path root_;  // canonical, or empty
};

}  // namespace myriad::loader
