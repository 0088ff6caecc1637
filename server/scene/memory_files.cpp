#include "scene/memory_files.h"

#include <filesystem>
#include <vector>

#include "scene/model_loader.h"

namespace myriad::scene {
namespace {

char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }

bool equalIgnoringCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

// Files of a model format that other models refer to rather than models of their own.
bool isCompanionOnly(std::string_view path) {
  const std::string extension = std::filesystem::path(path).extension().string();
  for (std::string_view companion : {".md5anim", ".md5camera"}) {
    if (equalIgnoringCase(extension, companion)) return true;
  }
  return false;
}

}  // namespace

std::optional<std::string> normalizeMemberPath(std::string_view path) {
  if (path.empty() || path.front() == '/' || path.front() == '\\') return std::nullopt;
  // "C:/..." or "C:\...": absolute on Windows, where such archives are made.
  if (path.size() >= 2 && path[1] == ':') return std::nullopt;
  std::vector<std::string_view> segments;
  size_t start = 0;
  for (size_t i = 0; i <= path.size(); ++i) {
    if (i < path.size() && static_cast<unsigned char>(path[i]) < 0x20) return std::nullopt;
    if (i < path.size() && path[i] != '/' && path[i] != '\\') continue;
    const std::string_view segment = path.substr(start, i - start);
    start = i + 1;
    if (segment.empty() || segment == ".") continue;
    if (segment == "..") {
      if (segments.empty()) return std::nullopt;
      segments.pop_back();
      continue;
    }
    segments.push_back(segment);
  }
  if (segments.empty()) return std::nullopt;
  std::string normalized;
  for (std::string_view segment : segments) {
    if (!normalized.empty()) normalized += '/';
    normalized += segment;
  }
  // Again on the result: "./C:/x" must not become the drive path "C:/x" (found by fuzz_upload_files).
  if (normalized.size() >= 2 && normalized[1] == ':') return std::nullopt;
  return normalized;
}

const std::string* findMember(const MemoryFiles& files, std::string_view path,
                              std::string* foundPath) {
  const std::optional<std::string> normalized = normalizeMemberPath(path);
  if (!normalized) return nullptr;
  auto it = files.find(*normalized);
  if (it == files.end()) {
    auto match = files.end();
    for (auto candidate = files.begin(); candidate != files.end(); ++candidate) {
      if (!equalIgnoringCase(candidate->first, *normalized)) continue;
      if (match != files.end()) return nullptr;  // ambiguous
      match = candidate;
    }
    it = match;
  }
  if (it == files.end()) return nullptr;
  if (foundPath != nullptr) *foundPath = it->first;
  return &it->second;
}

std::string modelEntryOf(const MemoryFiles& files, std::string_view entry, std::string_view name) {
  const std::string prefix = "Cannot load model '" + std::string(name) + "': ";
  if (!entry.empty()) {
    std::string found;
    if (findMember(files, entry, &found) == nullptr) {
      throw ModelLoadError(prefix + "it holds no file '" + std::string(entry) +
                               "' (the entry parameter)",
                           ModelLoadError::Kind::unsupported);
    }
    return found;
  }
  std::vector<std::string> models;
  for (const auto& [path, bytes] : files) {
    if (isSupportedModelExtension(std::filesystem::path(path).extension().string()) &&
        !isCompanionOnly(path)) {
      models.push_back(path);
    }
  }
  if (models.size() == 1) return models.front();
  if (models.empty()) {
    throw ModelLoadError(prefix + "none of its " + std::to_string(files.size()) +
                             " files is a model format this server reads",
                         ModelLoadError::Kind::unsupported);
  }
  std::string list;
  for (size_t i = 0; i < models.size() && i < 5; ++i) list += (i ? ", '" : "'") + models[i] + "'";
  if (models.size() > 5) list += ", ...";
  throw ModelLoadError(prefix + "it holds " + std::to_string(models.size()) + " model files (" +
                           list + "); name one with the entry parameter",
                       ModelLoadError::Kind::unsupported);
}

}  // namespace myriad::scene
