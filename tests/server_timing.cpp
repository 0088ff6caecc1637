#include "server_timing.h"

namespace myriad::test {

std::vector<std::string> serverTimingEntries(const std::string& header) {
  std::vector<std::string> entries;
  size_t start = 0;
  while (start < header.size()) {
    size_t end = header.find(',', start);
    if (end == std::string::npos) end = header.size();
    std::string entry = header.substr(start, end - start);
    while (!entry.empty() && entry.front() == ' ') entry.erase(0, 1);
    entries.push_back(entry);
    start = end + 1;
  }
  return entries;
}

}  // namespace myriad::test
