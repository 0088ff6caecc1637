// Uploads of several files (server/loader/archive.h, server/scene/memory_files.h): a zip archive
// as the loader child reads it (libzip from memory, entry checks, limits), or the parent -> child
// file-set wire (a multipart upload's files), then the choice of the model entry. Member paths of
// a multipart upload are normalized in the server process itself (normalizeMemberPath).
//
// Input: the first byte picks the reader (even: zip archive, odd: file set) and, with bit 1, the
// ?entry= asked for ("" or the first member's path with a changed case); the rest is the upload.
// Promises checked: only scene::ModelLoadError is thrown; every member path is what
// normalizeMemberPath makes of it; the set respects the limits; encodeFileSet/decodeFileSet give
// the same set back; modelEntryOf names a member of the set.
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_support.h"
#include "loader/archive.h"
#include "scene/memory_files.h"
#include "scene/model_loader.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;
using myriad::fuzz::broken;
using myriad::fuzz::require;

namespace {

// Smaller than the server's limits, so that one input cannot hold 512 MiB for the whole run;
// the checks are the same code at any size.
constexpr loader::ArchiveLimits kLimits{64, 16u << 20, 200};

void checkSet(const scene::MemoryFiles& files) {
  require(files.size() <= kLimits.maxEntries, "more entries than maxEntries");
  uint64_t bytes = 0;
  for (const auto& [path, data] : files) {
    require(scene::normalizeMemberPath(path) == path, "a member path that is not normalized");
    bytes += data.size();
  }
  require(bytes <= kLimits.maxBytes, "more bytes than maxBytes");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t selector = data[0];
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);

  // The server normalizes each multipart part's filename itself; any bytes may arrive there.
  if (const auto path = scene::normalizeMemberPath(bytes.substr(0, 300))) {
    require(scene::normalizeMemberPath(*path) == *path, "normalizeMemberPath is not idempotent");
  }

  scene::MemoryFiles files;
  try {
    files = (selector & 1) ? loader::decodeFileSet(bytes, "upload", kLimits)
                           : loader::readZipArchive(bytes, "upload.zip", kLimits);
  } catch (const scene::ModelLoadError& e) {
    require(std::string_view(e.what()).size() > 0, "a refusal without a sentence");
    return 0;
  }
  checkSet(files);
  try {
    require(loader::decodeFileSet(loader::encodeFileSet(files), "upload", kLimits) == files,
            "encodeFileSet/decodeFileSet changed the set");
  } catch (const scene::ModelLoadError& e) {
    broken(std::string("decodeFileSet refuses what encodeFileSet wrote: ") + e.what());
  }

  std::string entry;
  if ((selector & 2) && !files.empty()) {
    entry = files.begin()->first;
    std::transform(entry.begin(), entry.end(), entry.begin(),
                   [](unsigned char c) { return char(std::toupper(c)); });
  }
  try {
    const std::string chosen = scene::modelEntryOf(files, entry, "upload");
    require(scene::findMember(files, chosen) != nullptr, "modelEntryOf chose a missing member");
  } catch (const scene::ModelLoadError&) {
  }
  return 0;
}
