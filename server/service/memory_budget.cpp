#include "service/memory_budget.h"

#include <unistd.h>

#include <fstream>
#include <string>

#include "protocol/constants.h"
#include "service/problem.h"

namespace myriad::service {
namespace {

constexpr uint64_t kMiB = 1ull << 20;

std::string inMiB(uint64_t bytes) { return std::to_string((bytes + kMiB - 1) / kMiB) + " MiB"; }

}  // namespace

uint64_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0;
  uint64_t resident = 0;
  if (!(statm >> size >> resident)) return 0;
  return resident * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

uint64_t defaultMemoryLimit() {
  // cgroup v2 ("max" when unlimited), then v1 (a huge number when unlimited).
  for (const char* path : {"/sys/fs/cgroup/memory.max",
                           "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream file(path);
    std::string text;
    if (!(file >> text) || text == "max") continue;
    try {
      const uint64_t bytes = std::stoull(text);
      if (bytes > 0 && bytes < (1ull << 50)) return bytes;
    } catch (const std::exception&) {
    }
  }
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long pageSize = sysconf(_SC_PAGESIZE);
  if (pages <= 0 || pageSize <= 0) return 0;
  return static_cast<uint64_t>(pages) * static_cast<uint64_t>(pageSize) / 4 * 3;
}

MemoryBudget::Reservation& MemoryBudget::Reservation::operator=(Reservation&& other) noexcept {
  if (this != &other) {
    release();
    budget_ = other.budget_;
    bytes_ = other.bytes_;
    other.budget_ = nullptr;
    other.bytes_ = 0;
  }
  return *this;
}

void MemoryBudget::Reservation::release() {
  if (budget_ != nullptr) budget_->give(bytes_);
  budget_ = nullptr;
  bytes_ = 0;
}

uint64_t MemoryBudget::reserved() const {
  std::lock_guard lock(mutex_);
  return reserved_;
}

void MemoryBudget::give(uint64_t bytes) {
  {
    std::lock_guard lock(mutex_);
    reserved_ -= bytes;
  }
  freed_.notify_all();
}

MemoryBudget::Reservation MemoryBudget::reserve(uint64_t bytes, std::string_view what,
                                                std::chrono::milliseconds wait) {
  if (limit_ == 0) return Reservation(this, 0);
  if (floor_ + bytes > limit_) {
    throw ProblemError(limitExceeded(
        413, std::string(protocol::limits::kMaxMemoryBytes),
        std::string(what) + " needs about " + inMiB(bytes) + "; this server's --max-memory of " +
            inMiB(limit_) + " leaves " + inMiB(limit_ - std::min(limit_, floor_)) +
            " beside what it holds at start."));
  }
  const auto deadline = std::chrono::steady_clock::now() + wait;
  std::unique_lock lock(mutex_);
  while (true) {
    // What the process holds now includes what reserved requests have already made of their
    // reservations: counted twice while they run, which errs on the side of the limit.
    const uint64_t resident = residentBytes();
    if (resident + reserved_ + bytes <= limit_) {
      reserved_ += bytes;
      return Reservation(this, bytes);
    }
    if (freed_.wait_until(lock, deadline) == std::cv_status::timeout) {
      Problem problem = serverBusy(
          std::string(what) + " needs about " + inMiB(bytes) + "; the server holds " +
          inMiB(resident) + " and requests in progress have reserved " + inMiB(reserved_) +
          " of its --max-memory " + inMiB(limit_) + ".");
      problem.limit = std::string(protocol::limits::kMaxMemoryBytes);
      problem.retryAfterSeconds = 1;
      throw ProblemError(problem);
    }
  }
}

}  // namespace myriad::service
