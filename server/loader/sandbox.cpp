#include "loader/sandbox.h"

#include <fcntl.h>
#include <linux/landlock.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace myriad::loader {

namespace {

// Rights newer than the system's <linux/landlock.h> may know, by the ABI that added them.
constexpr uint64_t kFsRightsV1 = (1ull << 13) - 1;  // execute .. make_sym
constexpr uint64_t kFsRefer = 1ull << 13;           // ABI 2
constexpr uint64_t kFsTruncate = 1ull << 14;        // ABI 3
constexpr uint64_t kFsIoctlDev = 1ull << 15;        // ABI 5
constexpr uint64_t kNetBindTcp = 1ull << 0;         // ABI 4
constexpr uint64_t kNetConnectTcp = 1ull << 1;      // ABI 4
constexpr uint64_t kScopeAbstractUnix = 1ull << 0;  // ABI 6
constexpr uint64_t kScopeSignal = 1ull << 1;        // ABI 6
constexpr uint64_t kReadFile = 1ull << 2;
constexpr uint64_t kReadDir = 1ull << 3;

// struct landlock_ruleset_attr as of ABI 6; the size passed tells the kernel how much of it the
// caller knows, so older kernels get the prefix they understand.
struct RulesetAttr {
  uint64_t handledAccessFs;
  uint64_t handledAccessNet;
  uint64_t scoped;
};

struct PathBeneathAttr {
  uint64_t allowedAccess;
  int32_t parentFd;
} __attribute__((packed));

std::string failure(const char* step) { return std::string(step) + ": " + std::strerror(errno); }

}  // namespace

int landlockAbi() {
  const long abi =
      ::syscall(SYS_landlock_create_ruleset, nullptr, 0, LANDLOCK_CREATE_RULESET_VERSION);
  return abi > 0 ? int(abi) : 0;
}

std::string enterSandbox(const std::filesystem::path& readable) {
  const int abi = landlockAbi();
  if (abi == 0) return "the kernel offers no Landlock";

  RulesetAttr attr{};
  attr.handledAccessFs = kFsRightsV1 | (abi >= 2 ? kFsRefer : 0) | (abi >= 3 ? kFsTruncate : 0) |
                         (abi >= 5 ? kFsIoctlDev : 0);
  attr.handledAccessNet = abi >= 4 ? kNetBindTcp | kNetConnectTcp : 0;
  attr.scoped = abi >= 6 ? kScopeAbstractUnix | kScopeSignal : 0;
  const size_t size = abi >= 6 ? 24 : abi >= 4 ? 16 : 8;
  const int ruleset = int(::syscall(SYS_landlock_create_ruleset, &attr, size, 0));
  if (ruleset < 0) return failure("landlock_create_ruleset");

  std::string error;
  if (!readable.empty()) {
    const int directory = ::open(readable.c_str(), O_PATH | O_CLOEXEC);
    if (directory < 0) {
      error = failure("open the readable directory");
    } else {
      PathBeneathAttr rule{kReadFile | kReadDir, directory};
      if (::syscall(SYS_landlock_add_rule, ruleset, LANDLOCK_RULE_PATH_BENEATH, &rule, 0) != 0) {
        error = failure("landlock_add_rule");
      }
      ::close(directory);
    }
  }
  // Restricted even when the rule could not be added: then nothing is readable (fails closed).
  // No-new-privs is required to restrict an unprivileged process, and keeps set-uid programs out.
  if (::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
    error = failure("no_new_privs");
  } else if (::syscall(SYS_landlock_restrict_self, ruleset, 0) != 0) {
    error = failure("landlock_restrict_self");
  }
  ::close(ruleset);
  return error;
}

}  // namespace myriad::loader
