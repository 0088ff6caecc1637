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

bool isHexKey(std::string_view key) {
  if (key.size() != 64) return false;
  for (char c : key) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

bool isSessionId(std::string_view id) {
  if (id.size() != 18 || !id.starts_with("s-")) return false;
  for (char c : id.substr(2)) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

namespace {

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
                      {"version", s.version}, {"snapshot", s.snapshot}};
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
  // Records written before versions were kept have none: version 0.
  if (j.contains("version")) s.version = unsignedMember(j, "version", "");
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

nlohmann::json recordToJson(const StoredSession& session) { return toJson(session); }

StoredSession recordFromJson(const nlohmann::json& record, const StateLimits& limits) {
  return fromJson(record, limits);
}

void blobNamesOfRecord(std::string_view text, std::set<std::string>& named) {
  collectBlobNames(text, named);
}

std::vector<std::string> blobKeysOf(const StoredSession& session) {
  std::vector<std::string> keys;
  if (session.model) keys.push_back(session.model->blob);
  for (const StoredUpload& u : session.assets) keys.push_back(u.blob);
  if (session.environmentBlob) keys.push_back(*session.environmentBlob);
  return keys;
}

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

StatePersister::StatePersister(StateStore& store, uint32_t node, Collect collect,
                               Written written, std::chrono::milliseconds interval,
                               std::chrono::seconds retention)
    : store_(store),
      node_(node),
      collect_(std::move(collect)),
      written_(std::move(written)),
      interval_(interval),
      retention_(retention) {
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
    WriteResult result;
    try {
      result = store_.save(session, node_);
    } catch (const std::exception& e) {
      result = {WriteOutcome::failed, 0, e.what()};
    }
    if (result.outcome == WriteOutcome::failed) {
      std::fprintf(stderr, "myriad-server: state: session %s not saved: %s\n", session.id.c_str(),
                   result.detail.c_str());
    }
    if (written_) written_(session, result);
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
      try {
        sweeping = !store_.sweepSome(retention_, kSweepBatch);
      } catch (const std::exception& e) {
        // A store that went away: the sweep starts again next period.
        std::fprintf(stderr, "myriad-server: state: retention sweep stopped: %s\n", e.what());
        sweeping = false;
      }
      if (!sweeping) nextSweep = std::chrono::steady_clock::now() + kSweepPeriod;
    }
    lock.lock();
  }
}

}  // namespace myriad::service
