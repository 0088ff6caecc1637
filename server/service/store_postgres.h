// The state store in PostgreSQL (--state-store postgresql://...), for servers on many machines
// sharing sessions. Three tables, made at start when missing (under an advisory lock, so that
// servers starting together do not race):
//
//   myriad_sessions (id, version, record, blobs, updated_at)   a session's record (JSON text, as
//                   the file store writes it) at its version, and the blob keys it names
//   myriad_leases   (session_id, owner, epoch, expires_at, deleted)   one lease per session
//   myriad_blobs    (key, bytes, created_at)                   uploads' bytes by SHA-256
//
// Blobs are rows, not files in a shared volume the database would point into: one system to
// back up and restore, no volume every node must mount read-write (Kubernetes' ReadWriteMany),
// and a record and the blobs it names are never out of step. They are at most --max-upload-bytes
// (64 MiB by default, far under bytea's 1 GiB).
//
// Every change is one SQL statement, so no transaction is ever left open by a server that stops
// between two statements (SIGSTOP): a record write locks the session's lease row (FOR UPDATE) and
// inserts or updates the record only where that lease is still the writer's epoch and the record
// there is at no later version; a takeover updates the lease row, so it waits for a write in
// flight and then fences it. Expiry is on the database's clock (now()), never a node's. The
// connection sets statement_timeout, lock_timeout and idle_in_transaction_session_timeout, so a
// stopped server cannot hold a lock for long.
//
// A database that goes away is StoreUnavailable (a 503 naming it, for the request that needed it);
// a connection that broke is dropped and a new one made on the next call. The connection string
// is never logged or answered: describe() names the database and host only.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "service/state_store.h"

namespace myriad::service {

class PostgresStateStore final : public StateStore {
 public:
  // Connects once (throws std::runtime_error with one sentence when it cannot) and makes the
  // tables when missing.
  PostgresStateStore(std::string conninfo, StateLimits limits = {});
  ~PostgresStateStore() override;
  PostgresStateStore(const PostgresStateStore&) = delete;
  PostgresStateStore& operator=(const PostgresStateStore&) = delete;

  std::string describe() const override { return description_; }
  const StateLimits& limits() const override { return limits_; }

  std::string putBlob(std::string_view bytes) override;
  std::optional<std::string> blob(std::string_view key, std::string* why = nullptr) const override;
  WriteResult save(const StoredSession& session, uint32_t node) override;
  std::optional<StoredSession> load(std::string_view id) const override;
  void refuse(std::string_view id, std::string_view reason, bool remember) const override;
  bool forget(std::string_view id, uint32_t node, uint64_t epoch) override;
  LeaseGrant acquire(std::string_view id, uint32_t node, std::chrono::milliseconds ttl,
                     bool fresh, bool handover = false) override;
  std::vector<std::string> renew(uint32_t node,
                                 const std::vector<std::pair<std::string, uint64_t>>& held,
                                 std::chrono::milliseconds ttl,
                                 std::vector<std::string>* wanted = nullptr) override;
  void release(std::string_view id, uint32_t node, uint64_t epoch) override;
  bool sweepSome(std::chrono::seconds retention, size_t entries) override;

 private:
  class Pool;
  std::unique_ptr<Pool> pool_;
  StateLimits limits_;
  std::string description_;
  mutable std::mutex refusedMutex_;
  // The version of each record refused (refuse(remember)), so that it is reported once.
  mutable std::map<std::string, uint64_t, std::less<>> refused_;
  mutable std::map<std::string, uint64_t, std::less<>> loadedVersions_;
};

}  // namespace myriad::service
