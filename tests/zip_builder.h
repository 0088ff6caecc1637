// Zip archives built in memory for tests (libzip), including the hostile kinds an upload must
// refuse: paths leaving the archive, symbolic links, bombs.
#pragma once

#include <string>
#include <vector>

namespace myriad::test {

struct ZipEntry {
  std::string path;
  std::string data;
  bool symlink = false;  // stored as a Unix symbolic link whose target is `data`
  bool deflate = true;
};

std::string makeZip(const std::vector<ZipEntry>& entries);

}  // namespace myriad::test
