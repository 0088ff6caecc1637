// What every state store must do (service/state_store.h), checked the same way against the file
// store (state_store_tests.cpp, in `unit`) and PostgreSQL (store_postgres_tests.cpp, `store_pg`):
// versioned writes that never go back, leases taken, renewed, expired and stolen with the epoch
// fencing the former owner's writes, deletion that stays deleted, blobs by content, and a
// takeover racing a stale owner's writes losing none that the store said it wrote.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "service/state_store.h"

namespace myriad::service::contract {

using namespace std::chrono_literals;

inline StoredSession record(const std::string& id, uint64_t version, uint64_t epoch, int fov) {
  StoredSession s;
  s.id = id;
  s.version = version;
  s.epoch = epoch;
  s.tokenHash = sha256Hex("token");
  s.snapshot = {{"fov", fov}};
  return s;
}

inline bool contains(const std::vector<std::string>& ids, const std::string& id) {
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

// `a` and `b`: two handles on one store, as two server processes would have.
inline void checkStore(StateStore& a, StateStore& b) {
  const std::string id = "s-01aaaaaaaaaaaaaa";
  constexpr uint32_t kNode1 = 1, kNode2 = 2;

  // A fresh lease, and a second fresh take of the same id refused.
  LeaseGrant first = a.acquire(id, kNode1, 10s, true);
  REQUIRE(first.held);
  CHECK(first.lease.epoch == 1);
  CHECK_FALSE(b.acquire(id, kNode2, 10s, true).held);

  // Versioned writes: stored, the same version again (tokens only), never back.
  CHECK(a.save(record(id, 3, 1, 40), kNode1).outcome == WriteOutcome::written);
  std::optional<StoredSession> loaded = b.load(id);
  REQUIRE(loaded);
  CHECK(loaded->version == 3);
  CHECK(loaded->epoch == 1);
  CHECK(loaded->snapshot["fov"] == 40);
  CHECK(a.save(record(id, 3, 1, 41), kNode1).outcome == WriteOutcome::written);
  CHECK(a.save(record(id, 2, 1, 39), kNode1).outcome == WriteOutcome::stale);
  CHECK(b.load(id)->snapshot["fov"] == 41);

  // A live lease is not taken by another node; renewing keeps it.
  LeaseGrant refused = b.acquire(id, kNode2, 10s, false);
  CHECK_FALSE(refused.held);
  CHECK(refused.lease.owner == kNode1);
  CHECK(refused.lease.expiresInMs > 0);
  CHECK(a.renew(kNode1, {{id, 1}}, 300ms).empty());

  // Expired (300 ms, unrenewed): node 2 takes it over at epoch 2, and node 1 is fenced.
  std::this_thread::sleep_for(400ms);
  LeaseGrant stolen = b.acquire(id, kNode2, 10s, false);
  REQUIRE(stolen.held);
  CHECK(stolen.lease.epoch == 2);
  WriteResult stale = a.save(record(id, 9, 1, 99), kNode1);
  CHECK(stale.outcome == WriteOutcome::fenced);
  CHECK(stale.owner == kNode2);
  CHECK(contains(a.renew(kNode1, {{id, 1}}, 10s), id));
  CHECK(b.load(id)->snapshot["fov"] == 41);  // the fenced write is not there
  CHECK(b.save(record(id, 4, 2, 42), kNode2).outcome == WriteOutcome::written);
  CHECK(a.load(id)->version == 4);

  // Given back: node 1 takes it at once (epoch 3), and node 2's epoch is stale.
  b.release(id, kNode2, 2);
  LeaseGrant back = a.acquire(id, kNode1, 10s, false);
  REQUIRE(back.held);
  CHECK(back.lease.epoch == 3);
  CHECK(b.save(record(id, 5, 2, 43), kNode2).outcome == WriteOutcome::fenced);
  // Taking one's own lease again fences one's former self too (a restarted node).
  REQUIRE(a.acquire(id, kNode1, 10s, false).held);
  CHECK(a.save(record(id, 5, 3, 44), kNode1).outcome == WriteOutcome::fenced);
  CHECK(a.save(record(id, 5, 4, 44), kNode1).outcome == WriteOutcome::written);

  // The session's home node asks for a live lease (a handover): the owner hears it at its next
  // renewal and releases; then the home node takes it and the former owner is fenced.
  LeaseGrant asked = b.acquire(id, kNode2, 10s, false, true);
  CHECK_FALSE(asked.held);
  CHECK(asked.lease.owner == kNode1);
  std::vector<std::string> wanted;
  CHECK(a.renew(kNode1, {{id, 4}}, 10s, &wanted).empty());
  CHECK(wanted == std::vector<std::string>{id});
  a.release(id, kNode1, 4);
  LeaseGrant home = b.acquire(id, kNode2, 10s, false, true);
  REQUIRE(home.held);
  CHECK(home.lease.epoch == 5);
  wanted.clear();
  CHECK(b.renew(kNode2, {{id, 5}}, 10s, &wanted).empty());
  CHECK(wanted.empty());  // taken: the request is cleared
  WriteResult fencedByHome = a.save(record(id, 6, 4, 45), kNode1);
  CHECK(fencedByHome.outcome == WriteOutcome::fenced);
  CHECK(fencedByHome.owner == kNode2);
  b.release(id, kNode2, 5);
  REQUIRE(a.acquire(id, kNode1, 10s, false).held);  // epoch 6, node 1's again

  // Light ids and viewers travel with the record.
  StoredSession withIds = record(id, 6, 6, 45);
  withIds.lightIds = {5, 6, 7, 9, 3};
  withIds.nextLightId = 10;
  withIds.viewers = {{sha256Hex("viewer"), 1999999999}};
  CHECK(a.save(withIds, kNode1).outcome == WriteOutcome::written);
  loaded = b.load(id);
  REQUIRE(loaded);
  CHECK(loaded->lightIds == std::vector<uint64_t>{5, 6, 7, 9, 3});
  CHECK(loaded->nextLightId == 10);
  REQUIRE(loaded->viewers.size() == 1);
  CHECK(loaded->viewers[0].tokenHash == sha256Hex("viewer"));

  // Deleting: only by the owner; then nothing restores it, no write brings it back, and no node
  // takes its lease again.
  CHECK_FALSE(b.forget(id, kNode2, 5));
  CHECK(a.forget(id, kNode1, 6));
  CHECK_FALSE(b.load(id));
  CHECK(a.save(record(id, 7, 6, 46), kNode1).outcome == WriteOutcome::gone);
  LeaseGrant afterDelete = b.acquire(id, kNode2, 10s, false);
  CHECK_FALSE(afterDelete.held);
  CHECK(afterDelete.lease.deleted);
  CHECK_FALSE(b.load(id));

  // Blobs by content, checked against their key.
  const std::string key = a.putBlob("model bytes");
  CHECK(key == sha256Hex("model bytes"));
  CHECK(a.putBlob("model bytes") == key);
  CHECK(b.blob(key) == std::optional<std::string>("model bytes"));
  std::string why;
  CHECK_FALSE(b.blob("not-a-key", &why));
  CHECK(why == "not a blob key");
  CHECK_FALSE(b.blob(sha256Hex("never stored"), &why));
  CHECK(why == "it is missing");

  // A takeover racing a stale owner's writes: every write the store said it wrote is in what
  // the new owner loads, and none after.
  const std::string raced = "s-02bbbbbbbbbbbbbb";
  REQUIRE(a.acquire(raced, kNode1, 300ms, true).held);
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> lastWritten{0};
  uint64_t writtenAfterTakeover = 0;
  std::atomic<bool> takenOver{false};
  std::thread writer([&] {
    for (uint64_t v = 1; !stop; ++v) {
      const bool before = takenOver.load();
      WriteResult r = a.save(record(raced, v, 1, int(v)), kNode1);
      if (r.outcome == WriteOutcome::written) {
        lastWritten = v;
        if (before) ++writtenAfterTakeover;
      }
    }
  });
  std::this_thread::sleep_for(350ms);
  LeaseGrant took{};
  for (int i = 0; i < 100 && !took.held; ++i) {
    took = b.acquire(raced, kNode2, 10s, false);
    if (!took.held) std::this_thread::sleep_for(10ms);
  }
  REQUIRE(took.held);
  takenOver = true;
  std::optional<StoredSession> after = b.load(raced);
  std::this_thread::sleep_for(50ms);
  stop = true;
  writer.join();
  REQUIRE(after);
  CHECK(lastWritten.load() > 0);
  CHECK(after->version == lastWritten.load());
  CHECK(writtenAfterTakeover == 0);
}

}  // namespace myriad::service::contract
