// The embedded state store (--state-dir DIR): sessions and blobs as files under DIR, leases as
// files under DIR/leases, every lease and record change under an flock of DIR/.lock (store_files.h).
#include "service/store_files.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

namespace myriad::service {
namespace fs = std::filesystem;

namespace {

StateFileStamp stampOf(const struct stat& st) {
  return {uint64_t(st.st_ino), int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec,
          int64_t(st.st_size)};
}

// Now on the clock file times are on.
int64_t realtimeNs() {
  struct timespec now {};
  ::clock_gettime(CLOCK_REALTIME, &now);
  return int64_t(now.tv_sec) * 1000000000 + now.tv_nsec;
}

constexpr int64_t kNsPerSecond = 1000000000;

// Writes `bytes` to `path` so that a reader sees the old file or the whole new one, never a part:
// a temporary file beside it, fsync, rename, fsync of the directory. The temporary's name is this
// process's and this call's own, so servers sharing the directory never write into one file; one
// found there anyway (put there, perhaps as a link to a file elsewhere) is removed, and O_EXCL |
// O_NOFOLLOW makes sure the file written is a new one. Returns the stamp of the file written
// (rename keeps inode and mtime).
StateFileStamp writeAtomically(const fs::path& path, std::string_view bytes, bool sync = true) {
  static std::atomic<uint64_t> serial{0};
  const fs::path temporary = path.string() + ".tmp." + std::to_string(::getpid()) + "." +
                             std::to_string(serial.fetch_add(1));
  ::unlink(temporary.c_str());
  const int fd = ::open(temporary.c_str(),
                        O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("cannot write " + temporary.string());
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n <= 0) {
      ::close(fd);
      ::unlink(temporary.c_str());
      throw std::runtime_error("cannot write " + temporary.string() + " (disk full?)");
    }
    written += size_t(n);
  }
  bool synced = !sync || ::fsync(fd) == 0;
  struct stat st {};
  synced = synced && ::fstat(fd, &st) == 0;
  ::close(fd);
  if (!synced || ::rename(temporary.c_str(), path.c_str()) != 0) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("cannot replace " + path.string());
  }
  const int dirFd =
      sync ? ::open(path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC) : -1;
  if (dirFd >= 0) {
    ::fsync(dirFd);
    ::close(dirFd);
  }
  return stampOf(st);
}

std::string describeType(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a regular file";
}

// A file of the state directory as read: its bytes and the stamp of the version read, or no bytes
// and `refused` saying why (empty: there is no such file). `failed`: refused for an error of the
// system (no file descriptor left, an I/O error), not for what the file is, so it may read later.
struct FileRead {
  std::optional<std::string> bytes;
  std::string refused;
  bool failed = false;
  StateFileStamp stamp;
};

// Reads `name` (relative to `dirFd`, or a path with AT_FDCWD) when it is a regular file of at most
// `limit` bytes. O_NOFOLLOW refuses a symbolic link (a link to /dev/zero would be read forever),
// O_NONBLOCK keeps the open of a FIFO from waiting for a writer, and fstat then refuses all but a
// regular file. The limit is checked against the size and again while reading, since the file may
// grow meanwhile. One open file throughout, so another process replacing it does not mix versions.
FileRead readRegular(int dirFd, const char* name, uint64_t limit) {
  FileRead out;
  const int fd = ::openat(dirFd, name, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ELOOP) {
      out.refused = "it is a symbolic link";
    } else if (errno != ENOENT) {
      out.refused = std::string("it cannot be opened (") + std::strerror(errno) + ")";
      out.failed = true;
    }
    return out;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    out.refused = std::string("it cannot be read (") + std::strerror(errno) + ")";
    out.failed = true;
  } else if (!S_ISREG(st.st_mode)) {
    out.refused = "it is " + describeType(st.st_mode) + ", not a regular file";
  } else if (uint64_t(st.st_size) > limit) {
    out.refused = "it has " + std::to_string(st.st_size) + " bytes, over the limit of " +
                  std::to_string(limit);
  }
  if (!out.refused.empty()) {
    ::close(fd);
    return out;
  }
  out.stamp = stampOf(st);
  std::string bytes;
  bytes.reserve(size_t(st.st_size));
  std::vector<char> chunk(size_t(1) << 16);
  for (;;) {
    const ssize_t n = ::read(fd, chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      out.refused = std::string("it cannot be read (") + std::strerror(errno) + ")";
      out.failed = true;
      break;
    }
    if (n == 0) break;
    if (bytes.size() + size_t(n) > limit) {
      out.refused = "it grew past the limit of " + std::to_string(limit) + " bytes while read";
      break;
    }
    bytes.append(chunk.data(), size_t(n));
  }
  ::close(fd);
  if (out.refused.empty()) out.bytes = std::move(bytes);
  return out;
}

}  // namespace

// The retention sweep in progress: which directory it lists and where it is in it.
struct FileStateStore::Sweep {
  bool blobs = false;         // listing DIR/blobs (after DIR/sessions)
  // A session file could not be read for an error of the system, or the listing failed: the
  // blobs it names are unknown, so none is removed this time.
  bool namesUnknown = false;
  DIR* listing = nullptr;
  int64_t startNs = 0;        // when it began, on the clock of file times
  std::chrono::steady_clock::time_point began;
  std::set<std::string> named;  // blobs named by the session files read so far
  size_t files = 0;             // regular files looked at
  size_t sessionsRemoved = 0;
  size_t blobsRemoved = 0;
  ~Sweep() {
    if (listing != nullptr) ::closedir(listing);
  }
};

namespace {

// The flock of DIR/.lock for one transaction, taken under the store's mutex.
class DirLock {
 public:
  explicit DirLock(int fd) : fd_(fd) {
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno != EINTR) throw StoreUnavailable("the state directory's lock cannot be taken");
    }
  }
  ~DirLock() { ::flock(fd_, LOCK_UN); }
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;

 private:
  int fd_;
};

}  // namespace

// A lease file's content. `deleted`: the session was deleted (owner 0, expired); the epoch goes
// on from there should the id be used again.
struct FileStateStore::LeaseFile {
  uint32_t owner = 0;
  uint64_t epoch = 0;
  int64_t expiresAtMs = 0;
  uint64_t version = 0;  // the version of the record last written under the lock
  bool deleted = false;
  uint32_t wantedBy = kNobody;  // a node that asked for a handover (acquire's `handover`)
  static constexpr uint32_t kNobody = UINT32_MAX;
};

FileStateStore::FileStateStore(fs::path dir, StateLimits limits)
    : dir_(std::move(dir)), limits_(limits) {
  std::error_code error;
  for (const fs::path& sub : {dir_, dir_ / "sessions", dir_ / "blobs", dir_ / "leases"}) {
    fs::create_directories(sub, error);
    if (error || !fs::is_directory(sub)) {
      throw std::runtime_error("The state directory " + sub.string() + " cannot be created (" +
                               error.message() + ").");
    }
    ::chmod(sub.c_str(), 0700);
  }
  // Can we write there at all? Found now rather than at the first session.
  const fs::path probe = dir_ / "sessions" / ".probe";
  try {
    writeAtomically(probe, "");
    fs::remove(probe, error);
  } catch (const std::exception&) {
    throw std::runtime_error("The state directory " + dir_.string() + " is not writable.");
  }
  lockFd_ = ::open((dir_ / ".lock").c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (lockFd_ < 0) {
    throw std::runtime_error("The state directory's lock file " + (dir_ / ".lock").string() +
                             " cannot be opened (" + std::strerror(errno) + ").");
  }
}

FileStateStore::~FileStateStore() {
  if (lockFd_ >= 0) ::close(lockFd_);
}


std::string FileStateStore::putBlob(std::string_view bytes) {
  const std::string key = sha256Hex(bytes);
  const fs::path path = dir_ / "blobs" / key;
  // Compared without the lock (a blob may be the whole upload limit; every save takes the lock).
  const FileRead there = readRegular(AT_FDCWD, path.c_str(), limits_.blobBytes);
  const bool same = there.bytes && *there.bytes == bytes;
  std::lock_guard lock(mutex_);
  // The same bytes are renewed, so that a sweep under way (which keeps blobs written since it
  // began) keeps them; anything else under the key (other bytes, a FIFO, a link) is replaced, as
  // rename() replaces whatever the name was, and so is a blob the sweep removed meanwhile.
  if (!same || ::utimensat(AT_FDCWD, path.c_str(), nullptr, AT_SYMLINK_NOFOLLOW) != 0) {
    writeAtomically(path, bytes);
  }
  return key;
}

std::optional<std::string> FileStateStore::blob(std::string_view key, std::string* why) const {
  if (!isHexKey(key)) {
    if (why) *why = "not a blob key";
    return std::nullopt;
  }
  FileRead file = readRegular(AT_FDCWD, (dir_ / "blobs" / std::string(key)).c_str(),
                              limits_.blobBytes);
  if (why) *why = file.bytes ? "" : file.refused.empty() ? "it is missing" : file.refused;
  // A blob is named by its hash: a damaged one is as good as missing.
  if (file.bytes && sha256Hex(*file.bytes) != key) {
    if (why) *why = "its bytes are not the ones its name hashes";
    return std::nullopt;
  }
  return std::move(file.bytes);
}

fs::path FileStateStore::sessionPath(std::string_view id) const {
  return dir_ / "sessions" / (std::string(id) + ".json");
}

FileStateStore::LeaseFile FileStateStore::readLease(std::string_view id) const {
  LeaseFile lease;
  const FileRead file = readRegular(AT_FDCWD, (dir_ / "leases" / std::string(id)).c_str(), 256);
  if (!file.bytes) return lease;
  unsigned long long epoch = 0, version = 0;
  unsigned owner = 0, wanted = LeaseFile::kNobody;
  long long expires = 0;
  int deleted = 0;
  if (std::sscanf(file.bytes->c_str(), "%u %llu %lld %llu %d %u", &owner, &epoch, &expires,
                  &version, &deleted, &wanted) >= 4) {
    lease = {owner, epoch, expires, version, deleted != 0, wanted};
  } else {
    // A damaged lease file: its epoch is unknown, so the next one starts past any it could have
    // held (a stale owner's epoch is then certainly not the new one).
    lease.epoch = uint64_t(realtimeNs() / 1000);
    lease.deleted = false;
  }
  return lease;
}

void FileStateStore::writeLease(std::string_view id, const LeaseFile& lease, bool sync) const {
  char text[128];
  const int n = std::snprintf(text, sizeof text, "%u %llu %lld %llu %d %u\n", lease.owner,
                              static_cast<unsigned long long>(lease.epoch),
                              static_cast<long long>(lease.expiresAtMs),
                              static_cast<unsigned long long>(lease.version),
                              lease.deleted ? 1 : 0, lease.wantedBy);
  writeAtomically(dir_ / "leases" / std::string(id), std::string_view(text, size_t(n)), sync);
}

WriteResult FileStateStore::save(const StoredSession& session, uint32_t node) {
  if (!isSessionId(session.id)) throw std::invalid_argument("not a session id: " + session.id);
  const std::string text = recordToJson(session).dump();
  if (text.size() > limits_.recordBytes) {
    throw std::runtime_error("its record has " + std::to_string(text.size()) +
                             " bytes, over the " + std::to_string(limits_.recordBytes) +
                             " a restore reads");
  }
  std::lock_guard lock(mutex_);
  DirLock dirLock(lockFd_);
  LeaseFile lease = readLease(session.id);
  if (lease.deleted) return {WriteOutcome::gone, 0, ""};
  if (lease.epoch != session.epoch || lease.owner != node) {
    return {WriteOutcome::fenced, lease.owner, ""};
  }
  if (lease.version > session.version) return {WriteOutcome::stale, lease.owner, ""};
  try {
    stamps_[session.id] = writeAtomically(sessionPath(session.id), text);
    lease.version = session.version;
    writeLease(session.id, lease, false);
  } catch (const std::exception& e) {
    return {WriteOutcome::failed, 0, e.what()};
  }
  refused_.erase(session.id);
  return {};
}

std::optional<StoredSession> FileStateStore::load(std::string_view id) const {
  if (!isSessionId(id)) return std::nullopt;
  const fs::path path = sessionPath(id);
  struct stat st {};
  {
    std::lock_guard lock(mutex_);
    // A version refused already is not read (nor reported) again; lstat, since a link or a FIFO
    // has a version too.
    if (::lstat(path.c_str(), &st) != 0) return std::nullopt;
    if (auto it = refused_.find(id); it != refused_.end() && it->second == stampOf(st)) {
      return std::nullopt;
    }
  }
  // Read without the lock: a record may be large, and saves (every session create) take it.
  const FileRead file = readRegular(AT_FDCWD, path.c_str(), limits_.recordBytes);
  {
    std::lock_guard lock(mutex_);
    stamps_[std::string(id)] = file.bytes ? file.stamp : stampOf(st);
  }
  if (!file.bytes) {
    if (!file.refused.empty()) refuse(id, file.refused, !file.failed);
    return std::nullopt;
  }
  try {
    const nlohmann::json j = nlohmann::json::parse(*file.bytes);
    StoredSession session = recordFromJson(j, limits_);
    if (session.id != id) throw std::runtime_error("/id names another session");
    std::lock_guard lock(mutex_);
    DirLock dirLock(lockFd_);
    session.epoch = readLease(id).epoch;
    return session;
  } catch (const std::exception& e) {
    refuse(id, e.what(), true);
    return std::nullopt;
  }
}

void FileStateStore::refuse(std::string_view id, std::string_view reason, bool remember) const {
  if (remember) {
    std::lock_guard lock(mutex_);
    auto it = stamps_.find(id);
    if (it != stamps_.end()) refused_[std::string(id)] = it->second;
  }
  std::fprintf(stderr, "myriad-server: state: %s refused, its session not restored: %.*s\n",
               sessionPath(id).c_str(), int(reason.size()), reason.data());
}

bool FileStateStore::forget(std::string_view id, uint32_t node, uint64_t epoch) {
  if (!isSessionId(id)) return false;
  std::lock_guard lock(mutex_);
  DirLock dirLock(lockFd_);
  LeaseFile lease = readLease(id);
  if (lease.deleted) return true;
  if (lease.owner != node || lease.epoch != epoch) return false;
  lease = {0, lease.epoch + 1, 0, lease.version, true, LeaseFile::kNobody};
  writeLease(id, lease, true);
  std::error_code error;
  fs::remove(sessionPath(id), error);
  if (auto it = stamps_.find(id); it != stamps_.end()) stamps_.erase(it);
  if (auto it = refused_.find(id); it != refused_.end()) refused_.erase(it);
  return true;
}

LeaseGrant FileStateStore::acquire(std::string_view id, uint32_t node,
                                   std::chrono::milliseconds ttl, bool fresh, bool handover) {
  if (!isSessionId(id)) return {};
  std::lock_guard lock(mutex_);
  DirLock dirLock(lockFd_);
  LeaseFile lease = readLease(id);
  const int64_t now = realtimeNs() / 1000000;
  // A fresh session's id is new: any lease under it (an id given out twice) is not taken over.
  if (fresh && lease.epoch != 0) {
    return {false, {lease.owner, lease.epoch, lease.expiresAtMs - now}};
  }
  if (!lease.deleted && lease.owner != node && lease.expiresAtMs > now) {
    if (handover && lease.wantedBy != node) {
      lease.wantedBy = node;
      try {
        writeLease(id, lease, false);
      } catch (const std::exception&) {
        // Asked again at the next try.
      }
    }
    return {false, {lease.owner, lease.epoch, lease.expiresAtMs - now}};
  }
  // A deleted session keeps its lease deleted (its record is gone: the restore finds nothing).
  if (lease.deleted) return {false, {0, lease.epoch, 0, true}};
  lease.owner = node;
  lease.epoch += 1;
  lease.expiresAtMs = now + ttl.count();
  lease.wantedBy = LeaseFile::kNobody;
  try {
    writeLease(id, lease, true);
  } catch (const std::exception& e) {
    throw StoreUnavailable(std::string("the lease cannot be written: ") + e.what());
  }
  return {true, {lease.owner, lease.epoch, ttl.count()}};
}

std::vector<std::string> FileStateStore::renew(
    uint32_t node, const std::vector<std::pair<std::string, uint64_t>>& held,
    std::chrono::milliseconds ttl, std::vector<std::string>* wanted) {
  std::vector<std::string> lost;
  std::lock_guard lock(mutex_);
  DirLock dirLock(lockFd_);
  const int64_t now = realtimeNs() / 1000000;
  for (const auto& [id, epoch] : held) {
    LeaseFile lease = readLease(id);
    if (lease.deleted || lease.owner != node || lease.epoch != epoch) {
      lost.push_back(id);
      continue;
    }
    if (wanted != nullptr && lease.wantedBy != LeaseFile::kNobody) wanted->push_back(id);
    lease.expiresAtMs = now + ttl.count();
    try {
      // Not synced: a lease file older after a crash of the machine has only expired sooner.
      writeLease(id, lease, false);
    } catch (const std::exception& e) {
      throw StoreUnavailable(std::string("a lease cannot be written: ") + e.what());
    }
  }
  return lost;
}

void FileStateStore::release(std::string_view id, uint32_t node, uint64_t epoch) {
  if (!isSessionId(id)) return;
  std::lock_guard lock(mutex_);
  DirLock dirLock(lockFd_);
  LeaseFile lease = readLease(id);
  if (lease.deleted || lease.owner != node || lease.epoch != epoch) return;
  lease.expiresAtMs = 0;
  writeLease(id, lease, false);
}

bool FileStateStore::sweepSome(std::chrono::seconds retention, size_t entries) {
  std::lock_guard sweeping(sweepMutex_);
  if (!sweep_) {
    sweep_ = std::make_unique<Sweep>();
    sweep_->startNs = realtimeNs();
    sweep_->began = std::chrono::steady_clock::now();
    sweep_->listing = ::opendir((dir_ / "sessions").c_str());
    sweep_->namesUnknown = sweep_->listing == nullptr;
  }
  Sweep& sweep = *sweep_;
  const int64_t retentionNs = int64_t(retention.count()) * kNsPerSecond;
  for (size_t looked = 0; looked < entries; ++looked) {
    errno = 0;
    const dirent* entry = sweep.listing != nullptr ? ::readdir(sweep.listing) : nullptr;
    if (entry == nullptr) {
      if (errno != 0 && !sweep.blobs) sweep.namesUnknown = true;
      if (sweep.listing != nullptr) ::closedir(sweep.listing);
      sweep.listing = nullptr;
      if (sweep.blobs) {
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                                             sweep.began).count();
        std::fprintf(stderr,
                     "myriad-server: state: retention sweep looked at %zu files in %.1f s; "
                     "removed %zu session files and %zu blobs%s\n",
                     sweep.files, seconds, sweep.sessionsRemoved, sweep.blobsRemoved,
                     sweep.namesUnknown ? " (not all session files could be read: blobs kept)"
                                        : "");
        sweep_.reset();
        return true;
      }
      // Blobs only after every session file was read: one is removed only when none names it.
      sweep.blobs = true;
      sweep.listing = ::opendir((dir_ / "blobs").c_str());
      continue;
    }
    const char* name = entry->d_name;
    if (std::strcmp(name, ".") == 0 || std::strcmp(name, "..") == 0) continue;
    // The entry itself (lstat): links, FIFOs, devices and sockets are left alone, never opened.
    struct stat st {};
    if (::fstatat(::dirfd(sweep.listing), name, &st, AT_SYMLINK_NOFOLLOW) != 0 ||
        !S_ISREG(st.st_mode)) {
      continue;
    }
    ++sweep.files;
    const StateFileStamp seen = stampOf(st);
    const std::string_view file(name);
    const int64_t now = realtimeNs();
    if (sweep.blobs) {
      // Blobs written since a minute before the sweep began may be named by a file it did not
      // read (an upload's blob is written before its session file). A temporary left by a server
      // killed while writing is named by none.
      if (!sweep.namesUnknown && sweep.named.count(std::string(file)) == 0 &&
          seen.mtimeNs < std::min(now, sweep.startNs) - 60 * kNsPerSecond &&
          removeIfUnchanged(name, seen)) {
        ++sweep.blobsRemoved;
      }
      continue;
    }
    // A temporary left by a server killed while writing.
    if (file.find(".tmp.") != std::string_view::npos) {
      if (seen.mtimeNs < now - 60 * kNsPerSecond) removeIfUnchanged(name, seen);
      continue;
    }
    if (!file.ends_with(".json")) continue;
    if (seen.mtimeNs < now - retentionNs) {
      if (removeIfUnchanged(name, seen)) ++sweep.sessionsRemoved;
      continue;
    }
    // A file refused here names no blob; its restore says why.
    const FileRead read = readRegular(::dirfd(sweep.listing), name, limits_.recordBytes);
    if (read.bytes) blobNamesOfRecord(*read.bytes, sweep.named);
    if (read.failed) sweep.namesUnknown = true;
  }
  return false;
}

bool FileStateStore::removeIfUnchanged(const char* name, const StateFileStamp& seen) {
  const int dirFd = ::dirfd(sweep_->listing);
  // Under the lock that save() takes, and only the version the sweep looked at: a session saved
  // since (a new inode and mtime) stays.
  std::lock_guard lock(mutex_);
  struct stat st {};
  if (::fstatat(dirFd, name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !(stampOf(st) == seen)) {
    return false;
  }
  if (::unlinkat(dirFd, name, 0) != 0) return false;
  if (!sweep_->blobs) {
    std::string_view id(name);
    id.remove_suffix(std::min(id.size(), std::string_view(".json").size()));
    if (auto it = stamps_.find(id); it != stamps_.end()) stamps_.erase(it);
    if (auto it = refused_.find(id); it != refused_.end()) refused_.erase(it);
  }
  return true;
}

}  // namespace myriad::service
