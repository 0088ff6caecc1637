// The state store: where sessions survive the process and are shared between servers. An
// interface with two implementations, chosen by --state-store (main.cpp):
//
//   FileStateStore      (store_files.h)    --state-dir DIR: files under DIR, the embedded default
//                                          for one machine (several servers on it may share DIR)
//   PostgresStateStore  (store_postgres.h) --state-store postgresql://...: rows in PostgreSQL,
//                                          for servers on many machines
//
// Both keep the same things: each session's record (StoredSession: its snapshot, its token as a
// SHA-256 hash, its version), the bytes its uploads came from (blobs, by content), and one lease
// per session: which node serves it (owner), an epoch bumped whenever the lease changes hands, and
// an expiry the owner keeps pushing back (lease.h). Every write of a record carries the epoch it
// was made under and the session's version, and the store refuses it, in the same transaction
// that would write it, when the lease is no longer that epoch's (another node took the session
// over: a stale owner) or when the record there is at a later version (it would go back).
//
// The token itself is never written. What a store holds is untrusted input, like a request body:
// a record is checked member by member before use (recordFromJson), and the snapshot in it goes
// through the protocol's schema at restore, as a POSTed one does. A refused record is one line on
// stderr and is treated as absent: its session answers 404.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>
#include <condition_variable>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

namespace myriad::service {

// What rebuilds an uploaded model: the loader call and the bytes it was given.
struct StoredUpload {
  enum class Kind { file, zip, files };  // octet-stream with ?filename, zip, multipart (a file set)
  Kind kind = Kind::file;
  std::string filename;  // file: the name (its extension picks the format); zip: the archive's
  std::string entry;     // zip and files: the model inside ("" = the only one)
  std::string blob;      // key of the bytes (files: the loader's file-set encoding)
};

// The asset id of an upload stored under `blob`: the id the session gave it (assetIdOf() of the
// same bytes, "a-" + the first 16 hex digits of their SHA-256, which is the blob's key).
inline std::string assetIdOfBlob(std::string_view blob) {
  return "a-" + std::string(blob.substr(0, 16));
}

struct StoredSession {
  std::string id;
  // The session's version (Session::version) when this record was taken: a store never replaces
  // a record by one of a lower version.
  uint64_t version = 0;
  // Not part of the record: the lease epoch a write is made under, and the one a load found.
  uint64_t epoch = 0;
  std::string tokenHash;   // sha256Hex(token)
  // protocol::Snapshot: with its scene (assets by id and source, objects, semantic classes).
  nlohmann::json snapshot;
  std::optional<StoredUpload> model;        // when the snapshot's model was uploaded
  // The uploads behind the snapshot scene's other uploaded assets (POST .../assets), each the
  // asset assetIdOfBlob(blob); a restore loads them again before it restores the scene.
  std::vector<StoredUpload> assets;
  std::optional<std::string> environmentBlob;  // an uploaded environment, decoded floats
  // The lights' ids in the snapshot's order and the next id (a snapshot lists lights without
  // ids; a restored session keeps them). Empty lightIds: none stored.
  std::vector<uint64_t> lightIds;
  uint64_t nextLightId = 0;
  // Viewer tokens (POST .../tokens): SHA-256 and expiry in Unix seconds, like the owner's.
  struct Viewer {
    std::string tokenHash;
    int64_t expiresAtUnix = 0;
  };
  std::vector<Viewer> viewers;
};

// The most the store reads of one record or blob: a file over these is refused unread (fstat), a
// read that passes them is cut off, and a row over them is refused.
struct StateLimits {
  uint64_t recordBytes = 256ull << 20;  // DIR/sessions/<id>.json
  uint64_t blobBytes = 64ull << 20;     // DIR/blobs/<sha256>
  uint64_t lightIds = 1000000;          // ids in a record's lightIds (a session's lights at most)
  uint64_t assets = 64;                 // uploads in a record's assets (SceneGraph::kMaxAssets)
};

// The limits that fit a server with these API limits (--max-upload-bytes, --max-lights,
// --max-objects): nothing that server writes is over them.
StateLimits stateLimitsFor(uint64_t maxUploadBytes, uint64_t maxLightsPerSession,
                           uint64_t maxObjectsPerSession);

// Lower-case hex SHA-256 of `bytes` (OpenSSL).
std::string sha256Hex(std::string_view bytes);

// The hex digits of a SHA-256 (a blob's key), and a session id ("s-" + 16 hex digits): anything
// else never names a file or a row.
bool isHexKey(std::string_view key);
bool isSessionId(std::string_view id);

// A record as JSON and back (fromJson checks every member against `limits`; throws
// std::runtime_error naming the member as a JSON Pointer).
nlohmann::json recordToJson(const StoredSession& session);
StoredSession recordFromJson(const nlohmann::json& record, const StateLimits& limits);
// The blob keys a record's text names, without building its snapshot; nothing for non-JSON.
void blobNamesOfRecord(std::string_view text, std::set<std::string>& named);
// The blob keys a record names.
std::vector<std::string> blobKeysOf(const StoredSession& session);

// A session's lease as the store has it. `owner` is a node id (--node-id; 0 without one).
struct Lease {
  uint32_t owner = 0;
  uint64_t epoch = 0;        // 0: no lease (none was ever taken, or the session was deleted)
  int64_t expiresInMs = 0;   // how long it still runs on the store's clock; <= 0: expired
  bool deleted = false;      // the session was deleted: no node takes the lease again
};

// What acquire() gives: the lease now, and whether the node asking holds it (it did not when
// another node's lease has not expired).
struct LeaseGrant {
  bool held = false;
  Lease lease;
};

enum class WriteOutcome {
  written,  // the record is stored at its version
  fenced,   // the lease is no longer this write's epoch: another node owns the session (`owner`)
  stale,    // the record there is at a later version than this write's
  gone,     // the session was deleted (no lease, no record)
  failed,   // the store could not be reached or refused the write (`detail`)
};
struct WriteResult {
  WriteOutcome outcome = WriteOutcome::written;
  uint32_t owner = 0;   // fenced: the lease's owner now
  std::string detail;   // failed: why, in words (no connection string, no token)
};

// Thrown by a store that cannot be reached (a database that went away): the request that needed
// it is answered 503 naming the store, and the server serves everyone else.
class StoreUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class StateStore {
 public:
  virtual ~StateStore() = default;

  // What the store is, for log lines and problems ("the state directory /srv/state",
  // "PostgreSQL database myriad on /run/postgresql"): never a password.
  virtual std::string describe() const = 0;
  virtual const StateLimits& limits() const = 0;

  // Stores `bytes` under their hash (once) and returns the key. Throws on failure.
  virtual std::string putBlob(std::string_view bytes) = 0;
  // The bytes of `key`; nullopt when missing, not a key, over the limit or not the bytes the key
  // hashes, with the reason in `why` when given.
  virtual std::optional<std::string> blob(std::string_view key, std::string* why = nullptr) const = 0;

  // Writes the session's record under `session.epoch` (the lease the writer holds, as `node`) at
  // `session.version`, refused as WriteResult says. Throws only for a record over the limits.
  virtual WriteResult save(const StoredSession& session, uint32_t node) = 0;
  // The session's record, or nullopt when there is none or it is refused (reported with
  // refuse()). `epoch` of the result: its lease's epoch now. Throws StoreUnavailable.
  virtual std::optional<StoredSession> load(std::string_view id) const = 0;
  // Reports on stderr (one line) that the session's record is refused, and why. `remember`: the
  // record itself is at fault, so load() treats this version as absent without another line.
  virtual void refuse(std::string_view id, std::string_view reason, bool remember) const = 0;
  // Deletes the session (record and lease) if `node` holds its lease at `epoch`; a write of this
  // id is refused from then on (WriteOutcome::gone). False when the lease is another's.
  virtual bool forget(std::string_view id, uint32_t node, uint64_t epoch) = 0;

  // Takes the session's lease for `node` for `ttl` when it is free, expired or already this
  // node's; each time it is taken the epoch goes up by one (a node that takes its own lease again
  // after a restart fences its former self too). `fresh`: for a session just created (no record
  // yet). `handover`: when another node's lease is live, ask it to hand the session over (the
  // session's home node taking it back): renew() tells the owner, which closes its copy and
  // releases the lease, and a later acquire takes it. Throws StoreUnavailable.
  virtual LeaseGrant acquire(std::string_view id, uint32_t node, std::chrono::milliseconds ttl,
                             bool fresh, bool handover = false) = 0;
  // Extends the leases `node` holds (id and epoch) by `ttl`; returns those it no longer holds
  // (taken over, deleted), and in `wanted` those another node asked to be handed over. Throws
  // StoreUnavailable.
  virtual std::vector<std::string> renew(uint32_t node,
                                         const std::vector<std::pair<std::string, uint64_t>>& held,
                                         std::chrono::milliseconds ttl,
                                         std::vector<std::string>* wanted = nullptr) = 0;
  // Ends a lease `node` holds at `epoch` now (a session closed here: expiry, shutdown), so that
  // another node may take it at once. Nothing when it is no longer that lease.
  virtual void release(std::string_view id, uint32_t node, uint64_t epoch) = 0;

  // The retention sweep, a batch at a time: removes records not written for `retention` whose
  // lease has expired, then blobs no record names. Returns true when a sweep is complete.
  virtual bool sweepSome(std::chrono::seconds retention, size_t entries) = 0;
};

// Writes every session whose version moved since it was last written, at most every `interval`
// (a burst of edits is one write), on its own thread; flush() writes what is pending now. The same
// thread runs the retention sweep at start and every 10 minutes, a batch of entries between
// flushes (StateStore::sweepSome), so a directory of 20,000 sessions delays neither.
class StatePersister {
 public:
  // `collect` returns the sessions to write now (it takes each one's lock and snapshot);
  // `written` is told how each write went (a fenced one closes the copy). The persister calls
  // both from the thread that flushes, one flush at a time.
  using Collect = std::function<std::vector<StoredSession>()>;
  using Written = std::function<void(const StoredSession&, const WriteResult&)>;
  // Writes as lease owner `node`.
  StatePersister(StateStore& store, uint32_t node, Collect collect, Written written,
                 std::chrono::milliseconds interval, std::chrono::seconds retention);
  ~StatePersister();  // flushes, then stops
  StatePersister(const StatePersister&) = delete;
  StatePersister& operator=(const StatePersister&) = delete;

  // Writes what changed now. Callers on several threads are served one after the other, so a
  // session's record never goes back to an older version.
  void flush();

 private:
  void loop();

  StateStore& store_;
  const uint32_t node_;
  Collect collect_;
  Written written_;
  const std::chrono::milliseconds interval_;
  const std::chrono::seconds retention_;
  std::mutex mutex_;  // guards stopping_
  std::mutex flushMutex_;  // one flush at a time
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace myriad::service
