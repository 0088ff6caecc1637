// Sessions that survive the process (--state-dir DIR): each session's snapshot, its token as a
// SHA-256 hash, and the bytes its uploads came from, in files under DIR, so that a restarted
// server (or another server sharing DIR) restores a session on its first request.
//
//   DIR/sessions/<id>.json   one StoredSession, replaced atomically (temporary file, fsync, rename)
//   DIR/blobs/<sha256>       uploaded model bytes and decoded environment images, by content
//
// The token itself is never written: a restore needs a request that carries it, and checks it
// against the hash. Deleting a session removes its file; idle expiry only frees memory (the file
// stays for the retention period, --state-retention-hours). Blobs no session names are removed
// with the retention sweep.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>
#include <condition_variable>

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

struct StoredSession {
  std::string id;
  std::string tokenHash;   // sha256Hex(token)
  nlohmann::json snapshot; // protocol::Snapshot
  std::optional<StoredUpload> model;        // when the snapshot's model was uploaded
  std::optional<std::string> environmentBlob;  // an uploaded environment, decoded floats
  // Viewer tokens (POST .../tokens): SHA-256 and expiry in Unix seconds, like the owner's.
  struct Viewer {
    std::string tokenHash;
    int64_t expiresAtUnix = 0;
  };
  std::vector<Viewer> viewers;
};

// Lower-case hex SHA-256 of `bytes` (OpenSSL).
std::string sha256Hex(std::string_view bytes);

class StateStore {
 public:
  // Creates DIR/sessions and DIR/blobs (mode 0700) when missing. Throws std::runtime_error with
  // one sentence when DIR cannot be used.
  explicit StateStore(std::filesystem::path dir);

  const std::filesystem::path& dir() const { return dir_; }

  // Stores `bytes` under their hash (once: the same bytes are written once) and returns the key.
  std::string putBlob(std::string_view bytes);
  // The bytes of `key`; nullopt when missing (or not a key).
  std::optional<std::string> blob(std::string_view key) const;

  // Writes the session's file, replacing the previous one atomically.
  void save(const StoredSession& session);
  // The session's file, or nullopt when there is none or it cannot be read (a damaged file is
  // reported on stderr and treated as absent).
  std::optional<StoredSession> load(std::string_view id) const;
  void remove(std::string_view id);
  // remove(), and save() of this id is refused from now on (a write already collected when the
  // session was deleted must not bring its file back).
  void forget(std::string_view id);

  // Removes session files not written for `retention`, then blobs no remaining file names.
  // Returns how many session files went.
  size_t sweep(std::chrono::seconds retention);

 private:
  std::filesystem::path sessionPath(std::string_view id) const;
  std::filesystem::path dir_;
  mutable std::mutex mutex_;  // one writer of a path at a time; sweep against save
  std::set<std::string, std::less<>> forgotten_;
};

// Writes every session whose version moved since it was last written, at most every `interval`
// (a burst of edits is one write), on its own thread; flush() writes what is pending now.
class StatePersister {
 public:
  // `collect` returns the sessions to write now (it takes each one's lock and snapshot); the
  // persister calls it from its thread.
  using Collect = std::function<std::vector<StoredSession>()>;
  StatePersister(StateStore& store, Collect collect, std::chrono::milliseconds interval,
                 std::chrono::seconds retention);
  ~StatePersister();  // flushes, then stops
  StatePersister(const StatePersister&) = delete;
  StatePersister& operator=(const StatePersister&) = delete;

  void flush();

 private:
  void loop();

  StateStore& store_;
  Collect collect_;
  const std::chrono::milliseconds interval_;
  const std::chrono::seconds retention_;
  std::mutex mutex_;  // serializes flushes; guards stopping_
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace myriad::service
