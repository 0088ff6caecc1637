// Uploads of several files: a zip archive, or a set of files (what a multipart/form-data upload
// carries), turned into scene::MemoryFiles. Archives are untrusted input: they are read only in
// the loader child (child.cpp), and every limit below is checked before the bytes are held.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "scene/memory_files.h"

namespace myriad::loader {

// What an archive or file set may hold. The loader child's own memory limit (LoadLimits) stays
// the last word; these make a zip bomb a refusal naming the limit instead of an out-of-memory.
struct ArchiveLimits {
  uint32_t maxEntries = 1024;             // files in the upload (directories do not count)
  uint64_t maxBytes = 512ull << 20;       // uncompressed bytes of all files together
  // Uncompressed / compressed size of one entry. Real model data (text formats included) stays
  // well below 50:1; a deflate bomb is near 1000:1. Entries under 1 MiB are exempt.
  uint32_t maxCompressionRatio = 200;
};

// Names of the limits, as the refusals state them.
inline constexpr std::string_view kMaxArchiveEntries = "maxArchiveEntries";
inline constexpr std::string_view kMaxArchiveBytes = "maxArchiveBytes";
inline constexpr std::string_view kMaxCompressionRatio = "maxCompressionRatio";

// The files of zip archive `bytes` (`name` names it in messages). Refused, with
// scene::ModelLoadError: not a zip (parse); an entry that is absolute, leaves the archive
// (".."), is a symbolic link, is encrypted, or repeats another's path (unsupported); more entries,
// bytes or compression than `limits` allow (tooLarge, naming the limit); an entry whose data does
// not match its size or checksum (parse). Directories are skipped.
scene::MemoryFiles readZipArchive(std::string_view bytes, std::string_view name,
                                  const ArchiveLimits& limits);

// A file set on the parent -> child wire: u32 count, then per file u32 pathBytes, path,
// u64 dataBytes, data (little-endian, like the rest of the child protocol).
std::string encodeFileSet(const scene::MemoryFiles& files);
// The reverse, with the same checks on paths and limits as readZipArchive (the child does not
// trust what it is sent any more than it trusts an archive).
scene::MemoryFiles decodeFileSet(std::string_view bytes, std::string_view name,
                                 const ArchiveLimits& limits);

}  // namespace myriad::loader
