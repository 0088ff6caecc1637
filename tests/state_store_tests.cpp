// The embedded state store (service/store_files.h): the store contract (store_contract.h) with
// two handles on one directory, as two server processes sharing it would have, and concurrent
// writers that never leave a torn or temporary file behind.
#include <doctest/doctest.h>
#include <stdlib.h>

#include <filesystem>
#include <thread>

#include "service/store_files.h"
#include "store_contract.h"

using namespace myriad::service;

namespace {

// A state directory of its own under the system's temporary folder, removed at the end.
struct TemporaryDir {
  std::filesystem::path path;
  TemporaryDir() {
    char name[] = "/tmp/myriad-state-test-XXXXXX";
    path = ::mkdtemp(name);
  }
  ~TemporaryDir() {
    std::error_code error;
    std::filesystem::remove_all(path, error);
  }
};

}  // namespace

TEST_CASE("state store: files: versions, leases, fencing and deletion as the contract says") {
  TemporaryDir dir;
  FileStateStore a(dir.path);
  FileStateStore b(dir.path);
  contract::checkStore(a, b);
}

TEST_CASE("state store: files: concurrent writers of one session leave one whole file") {
  TemporaryDir dir;
  FileStateStore a(dir.path);
  FileStateStore b(dir.path);
  const std::string id = "s-03cccccccccccccc";
  REQUIRE(a.acquire(id, 1, std::chrono::seconds(10), true).held);
  // Both write as node 1 at epoch 1 (one owner's two threads): the versions decide.
  std::thread t1([&] {
    for (uint64_t i = 1; i <= 50; ++i) a.save(contract::record(id, i, 1, int(i)), 1);
  });
  std::thread t2([&] {
    for (uint64_t i = 1; i <= 50; ++i) b.save(contract::record(id, 100 + i, 1, int(100 + i)), 1);
  });
  t1.join();
  t2.join();
  std::optional<StoredSession> last = a.load(id);
  REQUIRE(last);
  CHECK(last->version == 150);
  CHECK(last->snapshot["fov"] == 150);
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path / "sessions")) {
    (void)entry;
    ++files;
  }
  CHECK(files == 1);
}
