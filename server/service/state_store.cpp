#include "service/state_store.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

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

// Writes `bytes` to `path` so that a reader sees the old file or the whole new one, never a part:
// a temporary file beside it, fsync, rename, fsync of the directory.
void writeAtomically(const fs::path& path, std::string_view bytes) {
  const fs::path temporary = path.string() + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
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
  const bool synced = ::fsync(fd) == 0;
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
}

std::optional<std::string> readWhole(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return std::move(text).str();
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

nlohmann::json toJson(const StoredSession& s) {
  nlohmann::json j = {{"format", 1}, {"id", s.id}, {"tokenSha256", s.tokenHash},
                      {"snapshot", s.snapshot}};
  if (s.model) {
    j["upload"] = {{"kind", kindName(s.model->kind)},
                   {"filename", s.model->filename},
                   {"entry", s.model->entry},
                   {"blob", s.model->blob}};
  }
  if (s.environmentBlob) j["environmentBlob"] = *s.environmentBlob;
  if (!s.viewers.empty()) {
    nlohmann::json viewers = nlohmann::json::array();
    for (const StoredSession::Viewer& v : s.viewers) {
      viewers.push_back({{"tokenSha256", v.tokenHash}, {"expiresAt", v.expiresAtUnix}});
    }
    j["viewerTokens"] = std::move(viewers);
  }
  return j;
}

StoredSession fromJson(const nlohmann::json& j) {
  if (j.at("format").get<int>() != 1) throw std::runtime_error("unknown format");
  StoredSession s;
  s.id = j.at("id").get<std::string>();
  s.tokenHash = j.at("tokenSha256").get<std::string>();
  if (!isHexKey(s.tokenHash)) throw std::runtime_error("bad token hash");
  s.snapshot = j.at("snapshot");
  if (j.contains("upload")) {
    const nlohmann::json& u = j.at("upload");
    StoredUpload upload;
    const std::string kind = u.at("kind").get<std::string>();
    upload.kind = kind == "zip"     ? StoredUpload::Kind::zip
                  : kind == "files" ? StoredUpload::Kind::files
                                    : StoredUpload::Kind::file;
    upload.filename = u.at("filename").get<std::string>();
    upload.entry = u.at("entry").get<std::string>();
    upload.blob = u.at("blob").get<std::string>();
    s.model = std::move(upload);
  }
  if (j.contains("environmentBlob")) s.environmentBlob = j.at("environmentBlob").get<std::string>();
  if (j.contains("viewerTokens")) {
    for (const nlohmann::json& v : j.at("viewerTokens")) {
      StoredSession::Viewer viewer{v.at("tokenSha256").get<std::string>(),
                                   v.at("expiresAt").get<int64_t>()};
      if (!isHexKey(viewer.tokenHash)) throw std::runtime_error("bad viewer token hash");
      s.viewers.push_back(std::move(viewer));
    }
  }
  return s;
}

}  // namespace

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

StateStore::StateStore(fs::path dir) : dir_(std::move(dir)) {
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

std::string StateStore::putBlob(std::string_view bytes) {
  const std::string key = sha256Hex(bytes);
  const fs::path path = dir_ / "blobs" / key;
  std::lock_guard lock(mutex_);
  std::error_code error;
  if (!fs::exists(path, error)) writeAtomically(path, bytes);
  return key;
}

std::optional<std::string> StateStore::blob(std::string_view key) const {
  if (!isHexKey(key)) return std::nullopt;
  std::optional<std::string> bytes = readWhole(dir_ / "blobs" / std::string(key));
  // A blob is named by its hash: a damaged one is as good as missing.
  if (bytes && sha256Hex(*bytes) != key) return std::nullopt;
  return bytes;
}

fs::path StateStore::sessionPath(std::string_view id) const {
  return dir_ / "sessions" / (std::string(id) + ".json");
}

void StateStore::save(const StoredSession& session) {
  if (!isSessionId(session.id)) throw std::invalid_argument("not a session id: " + session.id);
  const std::string text = toJson(session).dump();
  std::lock_guard lock(mutex_);
  if (forgotten_.contains(session.id)) return;
  writeAtomically(sessionPath(session.id), text);
}

std::optional<StoredSession> StateStore::load(std::string_view id) const {
  if (!isSessionId(id)) return std::nullopt;
  std::optional<std::string> text;
  {
    std::lock_guard lock(mutex_);
    text = readWhole(sessionPath(id));
  }
  if (!text) return std::nullopt;
  try {
    StoredSession session = fromJson(nlohmann::json::parse(*text));
    if (session.id != id) throw std::runtime_error("the file names another session");
    return session;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-server: state: %s is damaged (%s); not restored\n",
                 sessionPath(id).c_str(), e.what());
    return std::nullopt;
  }
}

void StateStore::remove(std::string_view id) {
  if (!isSessionId(id)) return;
  std::lock_guard lock(mutex_);
  std::error_code error;
  fs::remove(sessionPath(id), error);
}

void StateStore::forget(std::string_view id) {
  if (!isSessionId(id)) return;
  std::lock_guard lock(mutex_);
  forgotten_.emplace(id);
  std::error_code error;
  fs::remove(sessionPath(id), error);
}

size_t StateStore::sweep(std::chrono::seconds retention) {
  std::lock_guard lock(mutex_);
  std::error_code error;
  const auto cutoff = fs::file_time_type::clock::now() - retention;
  size_t removed = 0;
  std::set<std::string> named;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_ / "sessions", error)) {
    if (entry.path().extension() != ".json") continue;
    if (entry.last_write_time(error) < cutoff) {
      fs::remove(entry.path(), error);
      ++removed;
      continue;
    }
    if (std::optional<std::string> text = readWhole(entry.path())) {
      try {
        const nlohmann::json j = nlohmann::json::parse(*text);
        if (j.contains("upload")) named.insert(j["upload"].value("blob", ""));
        if (j.contains("environmentBlob")) named.insert(j["environmentBlob"].get<std::string>());
      } catch (const std::exception&) {
      }
    }
  }
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_ / "blobs", error)) {
    const std::string name = entry.path().filename().string();
    // Blobs only just written may not be named yet: keep them for a minute.
    if (named.count(name) == 0 &&
        entry.last_write_time(error) < fs::file_time_type::clock::now() - std::chrono::minutes(1)) {
      fs::remove(entry.path(), error);
    }
  }
  return removed;
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
  auto nextSweep = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, interval_, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    flush();
    if (std::chrono::steady_clock::now() >= nextSweep) {
      store_.sweep(retention_);
      nextSweep = std::chrono::steady_clock::now() + std::chrono::minutes(10);
    }
    lock.lock();
  }
}

}  // namespace myriad::service
