#include "loader/library.h"
#include "loader/loader.h"

#include <algorithm>
#include <stdexcept>
#include <system_error>

#include "scene/model_loader.h"

namespace myriad::loader {

namespace fs = std::filesystem;

namespace {

// Longer names are not models anyone placed there by hand.
constexpr size_t kMaxNameBytes = 1024;

bool isHidden(const fs::path& component) {
  const std::string text = component.string();
  return !text.empty() && text.front() == '.';
}

// Whether `path` (canonical) is `root` (canonical) or below it.
bool isWithin(const fs::path& path, const fs::path& root) {
  const fs::path relative = path.lexically_relative(root);
  return !relative.empty() && *relative.begin() != ".." && relative.is_relative();
}

}  // namespace

ModelLibrary::ModelLibrary(const fs::path& root) {
  if (root.empty()) return;
  std::error_code error;
  root_ = fs::canonical(root, error);
  if (error || !fs::is_directory(root_, error)) {
    throw std::runtime_error("--models '" + root.string() +
                             "' is not a directory that can be read" +
                             (error ? " (" + error.message() + ")" : std::string()) + ".");
  }
}

std::vector<LibraryEntry> ModelLibrary::list() const {
  std::vector<LibraryEntry> entries;
  if (root_.empty()) return entries;
  std::error_code error;
  fs::recursive_directory_iterator it(root_, fs::directory_options::skip_permission_denied, error);
  for (; !error && it != fs::recursive_directory_iterator(); it.increment(error)) {
    const fs::directory_entry& entry = *it;
    if (isHidden(entry.path().filename())) {
      if (entry.is_directory(error)) it.disable_recursion_pending();
      continue;
    }
    std::error_code ignored;
    if (!entry.is_regular_file(ignored)) continue;
    // Listed only if resolve() would serve it, so a name from the list always loads (a symlink
    // pointing out of the library is left out).
    const std::string name = entry.path().lexically_relative(root_).generic_string();
    const std::optional<fs::path> path = resolve(name);
    if (!path) continue;
    const uintmax_t bytes = fs::file_size(*path, ignored);
    if (ignored) continue;
    entries.push_back({name, uint64_t(bytes)});
  }
  std::sort(entries.begin(), entries.end(),
            [](const LibraryEntry& a, const LibraryEntry& b) { return a.name < b.name; });
  return entries;
}

std::optional<fs::path> ModelLibrary::resolve(std::string_view name) const {
  return resolveFile(name, false);
}

std::optional<fs::path> ModelLibrary::resolveEnvironment(std::string_view name) const {
  return resolveFile(name, true);
}

std::optional<fs::path> ModelLibrary::resolveFile(std::string_view name, bool environment) const {
  if (root_.empty() || name.empty() || name.size() > kMaxNameBytes) return std::nullopt;
  if (name.front() == '/' || name.find('\\') != std::string_view::npos ||
      name.find('\0') != std::string_view::npos) {
    return std::nullopt;
  }
  // Every component a plain visible name: no "", ".", ".." or ".hidden".
  size_t start = 0;
  while (start <= name.size()) {
    size_t end = name.find('/', start);
    if (end == std::string_view::npos) end = name.size();
    const std::string_view component = name.substr(start, end - start);
    if (component.empty() || component.front() == '.') return std::nullopt;
    start = end + 1;
  }
  const fs::path relative(name);
  if (environment ? !isEnvironmentFileName(relative.filename().string())
                  : !scene::isSupportedModelExtension(relative.extension().string())) {
    return std::nullopt;
  }

  // The checks above are lexical; symlinks are caught here, on the real path.
  std::error_code error;
  const fs::path real = fs::canonical(root_ / relative, error);
  if (error || !isWithin(real, root_)) return std::nullopt;
  if (!fs::is_regular_file(real, error)) return std::nullopt;
  return real;
}

}  // namespace myriad::loader
