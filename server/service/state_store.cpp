#include "service/state_store.h"

#include <dirent.h>
#include <fcntl.h>
#include <openssl/evp.h>
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

#include "protocol/constants.h"
#include "scene/environment_map.h"

namespace myriad::service {
namespace fs = std::filesystem;

namespace {

bool isHexKey(std::string_view key) {
  if (key.size() != 64) return false;
  for (char c : key) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// Session ids are "s-" + 16 hex digits; anything else never names a file.
bool isSessionId(std::string_view id) {
  if (id.size() != 18 || !id.starts_with("s-")) return false;
  for (char c : id.substr(2)) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

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
StateFileStamp writeAtomically(const fs::path& path, std::string_view bytes) {
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
  bool synced = ::fsync(fd) == 0;
  struct stat st {};
  synced = synced && ::fstat(fd, &st) == 0;
  ::close(fd);
  if (!synced || ::rename(temporary.c_str(), path.c_str()) != 0) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("cannot replace " + path.string());
  }
  const int dirFd = ::open(path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
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

const char* kindName(StoredUpload::Kind kind) {
  switch (kind) {
    case StoredUpload::Kind::zip:
      return "zip";
    case StoredUpload::Kind::files:
      return "files";
    case StoredUpload::Kind::file:
      break;
  }
  return "file";
}

nlohmann::json toJson(const StoredUpload& u) {
  return {{"kind", kindName(u.kind)},
          {"filename", u.filename},
          {"entry", u.entry},
          {"blob", u.blob}};
}

nlohmann::json toJson(const StoredSession& s) {
  nlohmann::json j = {{"format", 1}, {"id", s.id}, {"tokenSha256", s.tokenHash},
                      {"snapshot", s.snapshot}};
  if (s.model) j["upload"] = toJson(*s.model);
  if (!s.assets.empty()) {
    nlohmann::json assets = nlohmann::json::array();
    for (const StoredUpload& u : s.assets) assets.push_back(toJson(u));
    j["assets"] = std::move(assets);
  }
  if (s.environmentBlob) j["environmentBlob"] = *s.environmentBlob;
  if (!s.lightIds.empty()) {
    // As runs [first, count]: generated lights have consecutive ids, so a million of them is one.
    nlohmann::json runs = nlohmann::json::array();
    for (size_t i = 0; i < s.lightIds.size();) {
      size_t n = 1;
      while (i + n < s.lightIds.size() && s.lightIds[i + n] == s.lightIds[i] + n) ++n;
      runs.push_back({s.lightIds[i], n});
      i += n;
    }
    j["lightIds"] = std::move(runs);
    j["nextLightId"] = s.nextLightId;
  }
  if (!s.viewers.empty()) {
    nlohmann::json viewers = nlohmann::json::array();
    for (const StoredSession::Viewer& v : s.viewers) {
      viewers.push_back({{"tokenSha256", v.tokenHash}, {"expiresAt", v.expiresAtUnix}});
    }
    j["viewerTokens"] = std::move(viewers);
  }
  return j;
}

// A member of a record, or the reason the record is refused: the same words for every member.
const nlohmann::json& member(const nlohmann::json& j, const char* name, std::string_view at) {
  auto it = j.find(name);
  if (it == j.end()) throw std::runtime_error(std::string(at) + "/" + name + " is missing");
  return *it;
}

std::string stringMember(const nlohmann::json& j, const char* name, std::string_view at) {
  const nlohmann::json& value = member(j, name, at);
  if (!value.is_string()) throw std::runtime_error(std::string(at) + "/" + name + " is not a string");
  return value.get<std::string>();
}

uint64_t unsignedMember(const nlohmann::json& j, const char* name, std::string_view at) {
  const nlohmann::json& value = member(j, name, at);
  if (!value.is_number_unsigned()) {
    throw std::runtime_error(std::string(at) + "/" + name + " is not an unsigned integer");
  }
  return value.get<uint64_t>();
}

std::string keyMember(const nlohmann::json& j, const char* name, std::string_view at) {
  std::string key = stringMember(j, name, at);
  if (!isHexKey(key)) throw std::runtime_error(std::string(at) + "/" + name + " is not a SHA-256 in hex");
  return key;
}

// An upload of a record (its model's, or one of its assets'), checked member by member.
StoredUpload uploadFromJson(const nlohmann::json& u, const std::string& at) {
  if (!u.is_object()) throw std::runtime_error(at + " is not an object");
  StoredUpload upload;
  const std::string kind = stringMember(u, "kind", at);
  if (kind == "zip") {
    upload.kind = StoredUpload::Kind::zip;
  } else if (kind == "files") {
    upload.kind = StoredUpload::Kind::files;
  } else if (kind == "file") {
    upload.kind = StoredUpload::Kind::file;
  } else {
    throw std::runtime_error(at + "/kind is not file, zip or files");
  }
  upload.filename = stringMember(u, "filename", at);
  // As ?filename= is checked on upload (api_sessions.cpp uploadFilename).
  if (upload.filename.size() > 255 || upload.filename.find_first_of("/\\") != std::string::npos) {
    throw std::runtime_error(at + "/filename is not a file name of at most 255 bytes");
  }
  upload.entry = stringMember(u, "entry", at);
  upload.blob = keyMember(u, "blob", at);
  return upload;
}

// A session file's record, each member checked as a request's would be: its type, its range, the
// counts the server's limits allow. The snapshot is only checked to be an object here; the
// restore checks it against the protocol's schema, as the API checks a posted one. Throws
// std::runtime_error naming the member (as a JSON Pointer) and what is wrong with it.
StoredSession fromJson(const nlohmann::json& j, const StateLimits& limits) {
  if (!j.is_object()) throw std::runtime_error("the file is not a JSON object");
  if (unsignedMember(j, "format", "") != 1) throw std::runtime_error("/format is not 1");
  StoredSession s;
  s.id = stringMember(j, "id", "");
  s.tokenHash = keyMember(j, "tokenSha256", "");
  s.snapshot = member(j, "snapshot", "");
  if (!s.snapshot.is_object()) throw std::runtime_error("/snapshot is not an object");
  if (j.contains("upload")) s.model = uploadFromJson(j.at("upload"), "/upload");
  if (j.contains("assets")) {
    const nlohmann::json& assets = j.at("assets");
    if (!assets.is_array()) throw std::runtime_error("/assets is not an array");
    if (assets.size() > limits.assets) {
      throw std::runtime_error("/assets holds more than the " + std::to_string(limits.assets) +
                               " assets a session may have");
    }
    for (size_t i = 0; i < assets.size(); ++i) {
      s.assets.push_back(uploadFromJson(assets[i], "/assets/" + std::to_string(i)));
    }
  }
  if (j.contains("environmentBlob")) s.environmentBlob = keyMember(j, "environmentBlob", "");
  if (j.contains("lightIds")) {
    const nlohmann::json& runs = j.at("lightIds");
    if (!runs.is_array()) throw std::runtime_error("/lightIds is not an array");
    s.nextLightId = unsignedMember(j, "nextLightId", "");
    for (const nlohmann::json& run : runs) {
      if (!run.is_array() || run.size() != 2 || !run[0].is_number_unsigned() ||
          !run[1].is_number_unsigned()) {
        throw std::runtime_error("/lightIds holds a run that is not [first, count]");
      }
      const uint64_t first = run[0].get<uint64_t>();
      const uint64_t count = run[1].get<uint64_t>();
      // Counted before any id is made: a run of 2^40 ids is refused, not allocated.
      if (count > limits.lightIds - s.lightIds.size()) {
        throw std::runtime_error("/lightIds holds more than the " +
                                 std::to_string(limits.lightIds) + " lights a session may have");
      }
      if (first == 0 || first >= s.nextLightId || count > s.nextLightId - first) {
        throw std::runtime_error("/lightIds holds an id outside 1 .. nextLightId - 1");
      }
      for (uint64_t k = 0; k < count; ++k) s.lightIds.push_back(first + k);
    }
  }
  if (j.contains("viewerTokens")) {
    const nlohmann::json& viewers = j.at("viewerTokens");
    if (!viewers.is_array()) throw std::runtime_error("/viewerTokens is not an array");
    if (viewers.size() > protocol::kMaxViewerTokens) {
      throw std::runtime_error("/viewerTokens holds more than the " +
                               std::to_string(protocol::kMaxViewerTokens) + " a session keeps");
    }
    for (const nlohmann::json& v : viewers) {
      if (!v.is_object()) throw std::runtime_error("/viewerTokens holds a member that is not an object");
      const nlohmann::json& expires = member(v, "expiresAt", "/viewerTokens/*");
      if (!expires.is_number_integer()) {
        throw std::runtime_error("/viewerTokens/*/expiresAt is not an integer");
      }
      s.viewers.push_back({keyMember(v, "tokenSha256", "/viewerTokens/*"), expires.get<int64_t>()});
    }
  }
  return s;
}

// The blob keys a session file names (upload, assets, environment), without building its snapshot,
// which is most of the file and names none. Nothing for a file that is not JSON.
void collectBlobNames(std::string_view text, std::set<std::string>& named) {
  const nlohmann::json j = nlohmann::json::parse(
      text,
      [](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        return !(depth == 1 && event == nlohmann::json::parse_event_t::key && parsed == "snapshot");
      },
      false);
  if (!j.is_object()) return;
  if (auto u = j.find("upload"); u != j.end() && u->is_object()) {
    if (auto blob = u->find("blob"); blob != u->end() && blob->is_string()) {
      named.insert(blob->get<std::string>());
    }
  }
  if (auto e = j.find("environmentBlob"); e != j.end() && e->is_string()) {
    named.insert(e->get<std::string>());
  }
  if (auto assets = j.find("assets"); assets != j.end() && assets->is_array()) {
    for (const nlohmann::json& u : *assets) {
      if (!u.is_object()) continue;
      if (auto blob = u.find("blob"); blob != u.end() && blob->is_string()) {
        named.insert(blob->get<std::string>());
      }
    }
  }
}

}  // namespace

StateLimits stateLimitsFor(uint64_t maxUploadBytes, uint64_t maxLightsPerSession,
                           uint64_t maxObjectsPerSession) {
  StateLimits limits;
  // A record is its snapshot and a few hundred bytes. The API takes a snapshot of up to
  // maxUploadBytes, but a session grown by edits holds more than one that fits: per light, as
  // JSON, under 300 bytes and its id run under 30; per object a name of up to 256 characters
  // (escaped, up to 6 bytes each) and a transform; the materials are the model's, whose names
  // and textures come from the model's file (an upload has at most maxUploadBytes). 1 KiB a
  // light and 4 KiB an object leave room; should a record still be larger, save() refuses it
  // with a log line rather than write a file a restore would refuse.
  limits.recordBytes = 2 * maxUploadBytes + maxLightsPerSession * 1024 +
                       maxObjectsPerSession * 4096 + (uint64_t(1) << 20);
  // An upload as sent (at most maxUploadBytes; a multipart upload's file-set encoding spends 12
  // bytes a file where the multipart body spent more), or an environment's decoded floats.
  limits.blobBytes = std::max<uint64_t>(
      maxUploadBytes, uint64_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3 * 4);
  limits.lightIds = maxLightsPerSession;
  return limits;
}

std::string sha256Hex(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 failed");
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(length * 2);
  for (unsigned int i = 0; i < length; ++i) {
    hex.push_back(kHex[digest[i] >> 4]);
    hex.push_back(kHex[digest[i] & 15]);
  }
  return hex;
}

// The retention sweep in progress: which directory it lists and where it is in it.
struct StateStore::Sweep {
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

StateStore::StateStore(fs::path dir, StateLimits limits) : dir_(std::move(dir)), limits_(limits) {
  std::error_code error;
  for (const fs::path& sub : {dir_, dir_ / "sessions", dir_ / "blobs"}) {
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
}

StateStore::~StateStore() = default;

std::string StateStore::putBlob(std::string_view bytes) {
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

std::optional<std::string> StateStore::blob(std::string_view key, std::string* why) const {
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

fs::path StateStore::sessionPath(std::string_view id) const {
  return dir_ / "sessions" / (std::string(id) + ".json");
}

void StateStore::save(const StoredSession& session) {
  if (!isSessionId(session.id)) throw std::invalid_argument("not a session id: " + session.id);
  const std::string text = toJson(session).dump();
  if (text.size() > limits_.recordBytes) {
    throw std::runtime_error("its record has " + std::to_string(text.size()) +
                             " bytes, over the " + std::to_string(limits_.recordBytes) +
                             " a restore reads");
  }
  std::lock_guard lock(mutex_);
  if (forgotten_.contains(session.id)) return;
  stamps_[session.id] = writeAtomically(sessionPath(session.id), text);
  refused_.erase(session.id);
}

std::optional<StoredSession> StateStore::load(std::string_view id) const {
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
    StoredSession session = fromJson(j, limits_);
    if (session.id != id) throw std::runtime_error("/id names another session");
    return session;
  } catch (const std::exception& e) {
    refuse(id, e.what(), true);
    return std::nullopt;
  }
}

void StateStore::refuse(std::string_view id, std::string_view reason, bool remember) const {
  if (remember) {
    std::lock_guard lock(mutex_);
    auto it = stamps_.find(id);
    if (it != stamps_.end()) refused_[std::string(id)] = it->second;
  }
  std::fprintf(stderr, "myriad-server: state: %s refused, its session not restored: %.*s\n",
               sessionPath(id).c_str(), int(reason.size()), reason.data());
}

void StateStore::remove(std::string_view id) {
  if (!isSessionId(id)) return;
  std::lock_guard lock(mutex_);
  std::error_code error;
  fs::remove(sessionPath(id), error);
  if (auto it = stamps_.find(id); it != stamps_.end()) stamps_.erase(it);
  if (auto it = refused_.find(id); it != refused_.end()) refused_.erase(it);
}

bool StateStore::changedElsewhere(std::string_view id) const {
  std::lock_guard lock(mutex_);
  auto it = stamps_.find(id);
  if (it == stamps_.end()) return false;
  struct stat st {};
  if (::stat(sessionPath(id).c_str(), &st) != 0) return true;  // deleted by another server
  return !(stampOf(st) == it->second);
}

void StateStore::forget(std::string_view id) {
  if (!isSessionId(id)) return;
  std::lock_guard lock(mutex_);
  forgotten_.emplace(id);
  std::error_code error;
  fs::remove(sessionPath(id), error);
  if (auto it = stamps_.find(id); it != stamps_.end()) stamps_.erase(it);
  if (auto it = refused_.find(id); it != refused_.end()) refused_.erase(it);
}

bool StateStore::sweepSome(std::chrono::seconds retention, size_t entries) {
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
    if (read.bytes) collectBlobNames(*read.bytes, sweep.named);
    if (read.failed) sweep.namesUnknown = true;
  }
  return false;
}

bool StateStore::removeIfUnchanged(const char* name, const StateFileStamp& seen) {
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

StatePersister::StatePersister(StateStore& store, Collect collect,
                               std::chrono::milliseconds interval, std::chrono::seconds retention)
    : store_(store), collect_(std::move(collect)), interval_(interval), retention_(retention) {
  thread_ = std::thread([this] { loop(); });
}

StatePersister::~StatePersister() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
  flush();
}

void StatePersister::flush() {
  std::lock_guard lock(flushMutex_);
  for (const StoredSession& session : collect_()) {
    try {
      store_.save(session);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "myriad-server: state: session %s not saved: %s\n", session.id.c_str(),
                   e.what());
    }
  }
}

void StatePersister::loop() {
  // The sweep reads every session file (for the blobs they name): 20,000 of them are seconds of
  // one core. In batches of this many entries with a pause between, it takes no lock but per file
  // removed and a bounded share of the CPU, and the flush every `interval_` is not held up.
  constexpr size_t kSweepBatch = 256;
  constexpr auto kSweepPause = std::chrono::milliseconds(20);
  constexpr auto kSweepPeriod = std::chrono::minutes(10);
  auto nextSweep = std::chrono::steady_clock::now();
  auto nextFlush = std::chrono::steady_clock::now() + interval_;
  bool sweeping = false;
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, sweeping ? std::chrono::milliseconds(kSweepPause) : interval_,
                   [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    const auto now = std::chrono::steady_clock::now();
    if (now >= nextFlush) {
      flush();
      nextFlush = now + interval_;
    }
    if (sweeping || now >= nextSweep) {
      sweeping = !store_.sweepSome(retention_, kSweepBatch);
      if (!sweeping) nextSweep = std::chrono::steady_clock::now() + kSweepPeriod;
    }
    lock.lock();
  }
}

}  // namespace myriad::service
