// The embedded state store (--state-dir DIR), for one machine: every session's record, its
// lease, and the bytes its uploads came from, in files under DIR.
//
//   DIR/sessions/<id>.json   one StoredSession, replaced atomically (temporary file, fsync, rename)
//   DIR/leases/<id>          the session's lease: "owner epoch expiresAtUnixMs version"
//   DIR/blobs/<sha256>       uploaded model and asset bytes and decoded environment images, by
//                            content
//   DIR/.lock                flock()ed around every lease change and every record write
//
// Several servers on one machine may share DIR: a record is written only under the lock, after
// checking that the lease is still the writer's epoch and the record there not at a later
// version, so a stale owner's write fails instead of replacing another's (the same rules as the
// PostgreSQL store, with the lock for the transaction). flock() is only as good as the file
// system's: on a network file system use --state-store postgresql://... instead. Lease expiry is
// on the machine's real-time clock, which every server on it shares.
//
// The token itself is never written: a restore needs a request that carries it, and checks it
// against the hash. Deleting a session removes its record and leaves its lease, marked deleted,
// so an epoch is never given out twice; idle expiry only frees memory (the record stays for the
// retention period, --state-retention-hours). Blobs no record names are removed with the
// retention sweep.
//
// What is in DIR is untrusted input (state_store.h). Only regular files are opened (no links,
// FIFOs or devices: O_NOFOLLOW | O_NONBLOCK, then fstat), never more bytes than the largest file
// this server writes (StateLimits). A refused file is one line on stderr (once per version of the
// file, when the file itself is at fault) and is treated as absent: its session answers 404.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>

#include "service/state_store.h"

namespace myriad::service {

// Which version of a file: its inode changes with every atomic replacement; mtime and size
// besides, since a freed inode may be reused.
struct StateFileStamp {
  uint64_t inode = 0;
  int64_t mtimeNs = 0;
  int64_t size = 0;
  bool operator==(const StateFileStamp&) const = default;
};

class FileStateStore final : public StateStore {
 public:
  // Creates DIR/sessions, DIR/leases and DIR/blobs (mode 0700) when missing. Throws
  // std::runtime_error with one sentence when DIR cannot be used.
  explicit FileStateStore(std::filesystem::path dir, StateLimits limits = {});
  ~FileStateStore() override;

  const std::filesystem::path& dir() const { return dir_; }
  std::string describe() const override { return "the state directory " + dir_.string(); }
  const StateLimits& limits() const override { return limits_; }

  // The same bytes are written once; a blob already there has its mtime renewed, so that the
  // sweep keeps it.
  std::string putBlob(std::string_view bytes) override;
  std::optional<std::string> blob(std::string_view key, std::string* why = nullptr) const override;

  WriteResult save(const StoredSession& session, uint32_t node) override;
  std::optional<StoredSession> load(std::string_view id) const override;
  // `remember`: load() treats the version of the file it last read as absent from now on,
  // without reading it again or another line (a request a second for a damaged file is not a
  // line a second); a new version is read anew.
  void refuse(std::string_view id, std::string_view reason, bool remember) const override;
  bool forget(std::string_view id, uint32_t node, uint64_t epoch) override;

  LeaseGrant acquire(std::string_view id, uint32_t node, std::chrono::milliseconds ttl,
                     bool fresh, bool handover = false) override;
  std::vector<std::string> renew(uint32_t node,
                                 const std::vector<std::pair<std::string, uint64_t>>& held,
                                 std::chrono::milliseconds ttl,
                                 std::vector<std::string>* wanted = nullptr) override;
  void release(std::string_view id, uint32_t node, uint64_t epoch) override;

  // Each call looks at up to `entries` directory entries. The store's lock is taken per file
  // removed, never for the listing, so saves and restores go on meanwhile.
  bool sweepSome(std::chrono::seconds retention, size_t entries) override;

  // The session's file, as log lines name it.
  std::filesystem::path sessionPath(std::string_view id) const;

 private:
  struct Sweep;
  struct LeaseFile;
  // The lease file of `id` (absent: epoch 0); with the lock held.
  LeaseFile readLease(std::string_view id) const;
  void writeLease(std::string_view id, const LeaseFile& lease, bool sync) const;
  // Removes the entry `name` of the directory the sweep lists if it is still the version `seen`.
  bool removeIfUnchanged(const char* name, const StateFileStamp& seen);

  std::filesystem::path dir_;
  StateLimits limits_;
  int lockFd_ = -1;  // DIR/.lock
  // One writer of a path at a time in this process; the flock of DIR/.lock (taken under this
  // mutex: flock locks belong to the open file, which this process's threads share) against other
  // processes.
  mutable std::mutex mutex_;
  // The version of each session file this process last wrote or read, and of each one refused
  // (refuse()), so that it is reported once.
  mutable std::map<std::string, StateFileStamp, std::less<>> stamps_;
  mutable std::map<std::string, StateFileStamp, std::less<>> refused_;
  std::mutex sweepMutex_;  // one sweep at a time
  std::unique_ptr<Sweep> sweep_;  // the sweep in progress; null between sweeps
};

}  // namespace myriad::service
