#include "zip_builder.h"

#include <sys/stat.h>
#include <zip.h>

#include <stdexcept>

namespace myriad::test {

std::string makeZip(const std::vector<ZipEntry>& entries) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* buffer = zip_source_buffer_create(nullptr, 0, 0, &error);
  if (buffer == nullptr) throw std::runtime_error("zip_source_buffer_create failed");
  zip_source_keep(buffer);  // read back after zip_close
  zip_t* archive = zip_open_from_source(buffer, ZIP_TRUNCATE, &error);
  if (archive == nullptr) throw std::runtime_error("zip_open_from_source failed");
  for (const ZipEntry& entry : entries) {
    zip_source_t* data = zip_source_buffer(archive, entry.data.data(), entry.data.size(), 0);
    const zip_int64_t index =
        zip_file_add(archive, entry.path.c_str(), data, ZIP_FL_ENC_UTF_8 | ZIP_FL_OVERWRITE);
    if (index < 0) throw std::runtime_error("zip_file_add failed: " + entry.path);
    zip_set_file_compression(archive, zip_uint64_t(index),
                             entry.deflate ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 9);
    if (entry.symlink) {
      zip_file_set_external_attributes(archive, zip_uint64_t(index), 0, ZIP_OPSYS_UNIX,
                                       zip_uint32_t(S_IFLNK | 0777) << 16);
    }
  }
  if (zip_close(archive) != 0) throw std::runtime_error("zip_close failed");
  std::string bytes;
  if (zip_source_open(buffer) != 0) throw std::runtime_error("zip_source_open failed");
  char chunk[65536];
  for (zip_int64_t n; (n = zip_source_read(buffer, chunk, sizeof chunk)) > 0;) {
    bytes.append(chunk, size_t(n));
  }
  zip_source_close(buffer);
  zip_source_free(buffer);
  return bytes;
}

}  // namespace myriad::test
