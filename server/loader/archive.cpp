#include "loader/archive.h"

#include <sys/stat.h>
#include <zip.h>

#include <cstring>
#include <memory>
#include <optional>

#include "scene/model_loader.h"

namespace myriad::loader {
namespace {

using Kind = scene::ModelLoadError::Kind;

constexpr uint64_t kRatioExemptBytes = 1ull << 20;

[[noreturn]] void refuse(std::string_view name, const std::string& why, Kind kind) {
  throw scene::ModelLoadError("Cannot load model '" + std::string(name) + "': " + why, kind);
}

std::string quotedPath(std::string_view path) {
  // Entry names are client text: shown shortened, control characters already refused or replaced.
  std::string text(path.substr(0, 200));
  for (char& c : text) {
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  }
  return "'" + text + (path.size() > 200 ? "...'" : "'");
}

std::string mebibytes(uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// The checks an archive entry and a file-set member share; returns the normalized path.
std::string checkedPath(std::string_view path, std::string_view name, const scene::MemoryFiles& files) {
  const std::optional<std::string> normalized = scene::normalizeMemberPath(path);
  if (!normalized) {
    refuse(name, "its entry " + quotedPath(path) +
                     " is an absolute path or leaves the archive (..), which an upload may not",
           Kind::unsupported);
  }
  if (files.contains(*normalized)) {
    refuse(name, "it holds " + quotedPath(*normalized) + " twice", Kind::unsupported);
  }
  return *normalized;
}

void checkEntryCount(uint64_t count, std::string_view name, const ArchiveLimits& limits) {
  if (count > limits.maxEntries) {
    refuse(name, "it holds " + std::to_string(count) + " files, more than the " +
                     std::to_string(limits.maxEntries) + " an upload may hold (" +
                     std::string(kMaxArchiveEntries) + ")",
           Kind::tooLarge);
  }
}

void checkTotal(uint64_t total, std::string_view name, const ArchiveLimits& limits) {
  if (total > limits.maxBytes) {
    refuse(name, "its files hold more than " + mebibytes(limits.maxBytes) + " uncompressed (" +
                     std::string(kMaxArchiveBytes) + ")",
           Kind::tooLarge);
  }
}

struct ZipCloser {
  void operator()(zip_t* archive) const { zip_discard(archive); }
};
struct ZipFileCloser {
  void operator()(zip_file_t* file) const { zip_fclose(file); }
};

}  // namespace

scene::MemoryFiles readZipArchive(std::string_view bytes, std::string_view name,
                                  const ArchiveLimits& limits) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
  if (source == nullptr) refuse(name, "it cannot be read as a zip archive", Kind::parse);
  std::unique_ptr<zip_t, ZipCloser> archive(zip_open_from_source(source, ZIP_RDONLY, &error));
  if (!archive) {
    zip_source_free(source);
    const std::string why = zip_error_strerror(&error);
    zip_error_fini(&error);
    refuse(name, "it is not a zip archive (" + why + ")", Kind::parse);
  }
  zip_error_fini(&error);

  const zip_int64_t count = zip_get_num_entries(archive.get(), 0);
  if (count < 0) refuse(name, "its directory cannot be read", Kind::parse);
  checkEntryCount(uint64_t(count), name, limits);

  // Everything is checked from the directory before any entry is inflated, so a bomb costs
  // nothing; the sizes the directory declares are then enforced while reading.
  struct Entry {
    zip_uint64_t index;
    std::string path;
    uint64_t size;
  };
  std::vector<Entry> entries;
  scene::MemoryFiles files;
  uint64_t total = 0;
  for (zip_int64_t i = 0; i < count; ++i) {
    zip_stat_t stat;
    zip_stat_init(&stat);
    if (zip_stat_index(archive.get(), zip_uint64_t(i), 0, &stat) != 0 ||
        (stat.valid & (ZIP_STAT_NAME | ZIP_STAT_SIZE | ZIP_STAT_COMP_SIZE)) !=
            (ZIP_STAT_NAME | ZIP_STAT_SIZE | ZIP_STAT_COMP_SIZE)) {
      refuse(name, "its entry " + std::to_string(i) + " cannot be read", Kind::parse);
    }
    const std::string_view path = stat.name;
    if (!path.empty() && (path.back() == '/' || path.back() == '\\')) continue;  // a directory
    zip_uint8_t system = 0;
    zip_uint32_t attributes = 0;
    if (zip_file_get_external_attributes(archive.get(), zip_uint64_t(i), 0, &system,
                                         &attributes) == 0 &&
        system == ZIP_OPSYS_UNIX && S_ISLNK(attributes >> 16)) {
      refuse(name, "its entry " + quotedPath(path) + " is a symbolic link, which an upload may not hold",
             Kind::unsupported);
    }
    if ((stat.valid & ZIP_STAT_ENCRYPTION_METHOD) && stat.encryption_method != ZIP_EM_NONE) {
      refuse(name, "its entry " + quotedPath(path) + " is encrypted", Kind::unsupported);
    }
    const std::string normalized = checkedPath(path, name, files);
    files.emplace(normalized, std::string());  // reserves the path for the duplicate check
    if (stat.size > kRatioExemptBytes &&
        stat.size > uint64_t(limits.maxCompressionRatio) * std::max<uint64_t>(stat.comp_size, 1)) {
      refuse(name, "its entry " + quotedPath(path) + " expands " +
                       std::to_string(stat.size / std::max<uint64_t>(stat.comp_size, 1)) +
                       " times, more than the " + std::to_string(limits.maxCompressionRatio) +
                       " times an upload may (" + std::string(kMaxCompressionRatio) + ")",
             Kind::tooLarge);
    }
    total += stat.size;
    checkTotal(total, name, limits);
    entries.push_back(Entry{zip_uint64_t(i), normalized, stat.size});
  }

  for (const Entry& entry : entries) {
    std::unique_ptr<zip_file_t, ZipFileCloser> file(zip_fopen_index(archive.get(), entry.index, 0));
    if (!file) {
      refuse(name, "its entry " + quotedPath(entry.path) + " cannot be opened (" +
                       zip_strerror(archive.get()) + ")",
             Kind::parse);
    }
    std::string& data = files[entry.path];
    data.resize(entry.size);
    uint64_t read = 0;
    while (read < entry.size) {
      const zip_int64_t n = zip_fread(file.get(), data.data() + read, entry.size - read);
      if (n <= 0) break;
      read += uint64_t(n);
    }
    char extra = 0;
    // One more read: at the end it checks the CRC; data beyond the declared size is refused.
    const zip_int64_t after = read == entry.size ? zip_fread(file.get(), &extra, 1) : -1;
    if (read != entry.size || after != 0) {
      refuse(name, "its entry " + quotedPath(entry.path) +
                       " does not match its recorded size or checksum (a damaged archive)",
             Kind::parse);
    }
  }
  return files;
}

std::string encodeFileSet(const scene::MemoryFiles& files) {
  std::string out;
  const auto put = [&out](const void* value, size_t size) {
    out.append(static_cast<const char*>(value), size);
  };
  const uint32_t count = uint32_t(files.size());
  put(&count, sizeof count);
  for (const auto& [path, data] : files) {
    const uint32_t pathBytes = uint32_t(path.size());
    const uint64_t dataBytes = data.size();
    put(&pathBytes, sizeof pathBytes);
    out += path;
    put(&dataBytes, sizeof dataBytes);
    out += data;
  }
  return out;
}

scene::MemoryFiles decodeFileSet(std::string_view bytes, std::string_view name,
                                 const ArchiveLimits& limits) {
  size_t at = 0;
  const auto take = [&](void* value, size_t size) {
    if (bytes.size() - at < size) refuse(name, "the file set is truncated", Kind::parse);
    std::memcpy(value, bytes.data() + at, size);
    at += size;
  };
  uint32_t count = 0;
  take(&count, sizeof count);
  checkEntryCount(count, name, limits);
  scene::MemoryFiles files;
  uint64_t total = 0;
  for (uint32_t i = 0; i < count; ++i) {
    uint32_t pathBytes = 0;
    take(&pathBytes, sizeof pathBytes);
    if (pathBytes > 4096 || bytes.size() - at < pathBytes) {
      refuse(name, "the file set is truncated", Kind::parse);
    }
    const std::string_view path = bytes.substr(at, pathBytes);
    at += pathBytes;
    const std::string normalized = checkedPath(path, name, files);
    uint64_t dataBytes = 0;
    take(&dataBytes, sizeof dataBytes);
    if (bytes.size() - at < dataBytes) refuse(name, "the file set is truncated", Kind::parse);
    total += dataBytes;
    checkTotal(total, name, limits);
    files.emplace(normalized, std::string(bytes.substr(at, dataBytes)));
    at += dataBytes;
  }
  if (at != bytes.size()) refuse(name, "the file set has trailing bytes", Kind::parse);
  return files;
}

}  // namespace myriad::loader
