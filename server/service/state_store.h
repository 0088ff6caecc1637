// Sessions that survive the process (--state-dir DIR): each session's snapshot, its token as a
// SHA-256 hash, and the bytes its uploads came from, in files under DIR, so that a restarted
// server (or another server sharing DIR) restores a session on its first request.
//
//   DIR/sessions/<id>.json   one StoredSession, replaced atomically (temporary file, fsync, rename)
//   DIR/blobs/<sha256>       uploaded model and asset bytes and decoded environment images, by
//                            content
//
// The token itself is never written: a restore needs a request that carries it, and checks it
// against the hash. Deleting a session removes its file; idle expiry only frees memory (the file
// stays for the retention period, --state-retention-hours). Blobs no session names are removed
// with the retention sweep.
//
// What is in DIR is untrusted input, like a request body: anyone who can write there (another
// process, a shared volume, a restored backup) could have put anything there. Only regular files
// are opened (no links, FIFOs or devices: O_NOFOLLOW | O_NONBLOCK, then fstat), never more bytes
// than the largest file this server writes (StateLimits), and a record is checked member by member
// before use; the snapshot in it goes through the protocol's schema at restore, as a POSTed one
// does. A refused file is one line on stderr (once per version of the file, when the file itself
// is at fault) and is treated as absent: its session answers 404.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
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

// The most the store reads of one file: a file over these is refused unread (fstat), and a read
// that passes them is cut off, so a file that grows while read cannot take the memory either.
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

// Which version of a file: its inode changes with every atomic replacement; mtime and size
// besides, since a freed inode may be reused.
struct StateFileStamp {
  uint64_t inode = 0;
  int64_t mtimeNs = 0;
  int64_t size = 0;
  bool operator==(const StateFileStamp&) const = default;
};

class StateStore {
 public:
  // Creates DIR/sessions and DIR/blobs (mode 0700) when missing. Throws std::runtime_error with
  // one sentence when DIR cannot be used.
  explicit StateStore(std::filesystem::path dir, StateLimits limits = {});
  ~StateStore();

  const std::filesystem::path& dir() const { return dir_; }
  const StateLimits& limits() const { return limits_; }

  // Stores `bytes` under their hash (once: the same bytes are written once; a blob already there
  // has its mtime renewed, so that the sweep keeps it) and returns the key.
  std::string putBlob(std::string_view bytes);
  // The bytes of `key`; nullopt when missing, not a key, not a regular file, over the limit or
  // not the bytes the key hashes, with the reason in `why` when given.
  std::optional<std::string> blob(std::string_view key, std::string* why = nullptr) const;

  // Writes the session's file, replacing the previous one atomically.
  void save(const StoredSession& session);
  // The session's file, or nullopt when there is none or it is refused (not a regular file, over
  // the limit, not a record: reported with refuse()).
  std::optional<StoredSession> load(std::string_view id) const;
  // The session's file, as log lines name it.
  std::filesystem::path sessionPath(std::string_view id) const;
  // Reports on stderr (one line) that the session's file is refused, and why. `remember`: the
  // file's own content is at fault (not a record, not the schema), so load() treats the version
  // it last read as absent from now on, without reading it again or another line (a request a
  // second for a damaged file is not a line a second); a new version is read anew. Without it
  // (a model that no longer loads, which a change to the library may mend) the next request
  // tries again.
  void refuse(std::string_view id, std::string_view reason, bool remember) const;
  void remove(std::string_view id);
  // remove(), and save() of this id is refused from now on (a write already collected when the
  // session was deleted must not bring its file back).
  void forget(std::string_view id);

  // True when the session's file is no longer the one this process last wrote or read: another
  // server sharing DIR wrote it (or deleted it) since. A session open here is then stale and must
  // be restored from the file again. False for a session this process never wrote nor read.
  bool changedElsewhere(std::string_view id) const;

  // The retention sweep, a batch at a time: removes session files not written for `retention`,
  // then blobs no remaining file names. Each call looks at up to `entries` directory entries and
  // returns true when the sweep is complete (the next call starts another). The store's lock is
  // taken per file removed, never for the listing, so saves and restores go on meanwhile.
  bool sweepSome(std::chrono::seconds retention, size_t entries);

 private:
  struct Sweep;
  // Removes the entry `name` of the directory the sweep lists if it is still the version `seen`.
  bool removeIfUnchanged(const char* name, const StateFileStamp& seen);

  std::filesystem::path dir_;
  StateLimits limits_;
  mutable std::mutex mutex_;  // one writer of a path at a time; sweep against save
  std::set<std::string, std::less<>> forgotten_;
  // What each session file was when this process last wrote or read it.
  mutable std::map<std::string, StateFileStamp, std::less<>> stamps_;
  // The version of each session file refused (refuse()), so that it is reported once.
  mutable std::map<std::string, StateFileStamp, std::less<>> refused_;
  std::mutex sweepMutex_;  // one sweep at a time
  std::unique_ptr<Sweep> sweep_;  // the sweep in progress; null between sweeps
};

// Writes every session whose version moved since it was last written, at most every `interval`
// (a burst of edits is one write), on its own thread; flush() writes what is pending now. The same
// thread runs the retention sweep at start and every 10 minutes, a batch of entries between
// flushes (StateStore::sweepSome), so a directory of 20,000 sessions delays neither.
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

  // Writes what changed now. Callers on several threads are served one after the other, so a
  // session's file never goes back to an older version.
  void flush();

 private:
  void loop();

  StateStore& store_;
  Collect collect_;
  const std::chrono::milliseconds interval_;
  const std::chrono::seconds retention_;
  std::mutex mutex_;  // guards stopping_
  std::mutex flushMutex_;  // one flush at a time
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace myriad::service
