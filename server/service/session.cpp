#include "service/session.h"

#include <sys/random.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <stdexcept>

#include "service/state_store.h"

namespace myriad::service {
namespace {

constexpr size_t kTokenBytes = 32;
constexpr size_t kIdBytes = 8;
constexpr std::string_view kBearerPrefix = "Bearer ";

// Tokens guard a session; they come from the kernel's CSPRNG, never from a seeded engine.
std::string randomHex(size_t bytes) {
  std::vector<unsigned char> buffer(bytes);
  size_t filled = 0;
  while (filled < bytes) {
    ssize_t n = getrandom(buffer.data() + filled, bytes - filled, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error("getrandom failed");
    }
    filled += size_t(n);
  }
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  text.reserve(bytes * 2);
  for (unsigned char b : buffer) {
    text.push_back(kDigits[b >> 4]);
    text.push_back(kDigits[b & 15]);
  }
  return text;
}

}  // namespace

std::string randomToken() { return randomHex(kTokenBytes); }

int64_t unixNow() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Session::Session(std::string id, std::string token, SessionScene scene)
    : id(std::move(id)),
      token(std::move(token)),
      tokenHash(sha256Hex(this->token)),
      scene(std::move(scene)) {}

Session::Session(std::string id, std::string token, std::string tokenHash, SessionScene scene)
    : id(std::move(id)),
      token(std::move(token)),
      tokenHash(std::move(tokenHash)),
      scene(std::move(scene)) {}

bool constantTimeEquals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char difference = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    difference |= static_cast<unsigned char>(a[i] ^ b[i]);
  }
  // Through a volatile so the compiler cannot turn the loop into an early exit.
  volatile unsigned char result = difference;
  return result == 0;
}

std::optional<std::string> bearerToken(std::string_view authorization) {
  if (!authorization.starts_with(kBearerPrefix)) return std::nullopt;
  std::string_view token = authorization.substr(kBearerPrefix.size());
  if (token.empty() || token.size() > 256) return std::nullopt;
  for (char c : token) {
    if (c <= ' ' || c > '~') return std::nullopt;
  }
  return std::string(token);
}

SessionManager::SessionManager(uint32_t maxSessions, std::chrono::seconds idleTimeout,
                               SceneReleaser release)
    : maxSessions_(maxSessions), idleTimeout_(idleTimeout), release_(std::move(release)) {
  sweeper_ = std::thread([this] { sweeperLoop(); });
}

SessionManager::~SessionManager() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  sweeperWake_.notify_all();
  if (sweeper_.joinable()) sweeper_.join();
  closeAll();
}

SessionPtr SessionManager::create(SessionScene scene) {
  std::lock_guard lock(mutex_);
  if (sessions_.size() >= maxSessions_) {
    throw ProblemError(limitExceeded(
        429, "maxSessions",
        "The server already holds " + std::to_string(sessions_.size()) +
            " sessions, its limit; delete one or wait for an idle one to expire."));
  }
  std::string id;
  do {
    id = "s-" + nodeHex_ + randomHex(kIdBytes).substr(nodeHex_.size());
  } while (sessions_.contains(id));
  auto session = std::make_shared<Session>(id, randomHex(kTokenBytes), std::move(scene));
  session->persisted.fresh = true;  // its first write takes a new lease (session_sync.h)
  sessions_.emplace(id, session);
  return session;
}

void SessionManager::setNode(uint32_t node) {
  static constexpr char kDigits[] = "0123456789abcdef";
  nodeHex_ = {kDigits[(node >> 4) & 15], kDigits[node & 15]};
}

SessionPtr SessionManager::createWithIdentity(std::string id, std::string token,
                                             std::string tokenHash, SessionScene scene) {
  std::lock_guard lock(mutex_);
  if (sessions_.size() >= maxSessions_) {
    throw ProblemError(limitExceeded(
        429, "maxSessions",
        "The server already holds " + std::to_string(sessions_.size()) +
            " sessions, its limit; the session cannot be restored until one is deleted or expires."));
  }
  auto session = std::make_shared<Session>(id, std::move(token), std::move(tokenHash),
                                          std::move(scene));
  session->restoring = true;  // until authorize()'s restorer returns it
  sessions_.emplace(std::move(id), session);
  return session;
}

std::vector<SessionPtr> SessionManager::all() const {
  std::lock_guard lock(mutex_);
  std::vector<SessionPtr> open;
  open.reserve(sessions_.size());
  for (const auto& [id, session] : sessions_) open.push_back(session);
  return open;
}

SessionPtr SessionManager::find(std::string_view id) const {
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(id);
  return it == sessions_.end() ? nullptr : it->second;
}

// The restore lock of one id, held for its scope; the map forgets an id no one holds.
class SessionManager::RestoreLock {
 public:
  RestoreLock(SessionManager& manager, std::string_view id) : manager_(manager), id_(id) {
    {
      std::lock_guard lock(manager_.restoreLocksMutex_);
      std::shared_ptr<std::mutex>& slot = manager_.restoreLocks_[id_];
      if (!slot) slot = std::make_shared<std::mutex>();
      mutex_ = slot;
    }
    mutex_->lock();
  }
  ~RestoreLock() {
    mutex_->unlock();
    std::lock_guard lock(manager_.restoreLocksMutex_);
    mutex_.reset();
    auto it = manager_.restoreLocks_.find(id_);
    if (it != manager_.restoreLocks_.end() && it->second.use_count() == 1) {
      manager_.restoreLocks_.erase(it);
    }
  }
  RestoreLock(const RestoreLock&) = delete;
  RestoreLock& operator=(const RestoreLock&) = delete;

 private:
  SessionManager& manager_;
  std::string id_;
  std::shared_ptr<std::mutex> mutex_;
};

SessionPtr SessionManager::authorize(std::string_view id, const Credentials& credentials,
                                     bool allowQueryToken, Role needed, Role* role) {
  std::optional<std::string> token;
  if (credentials.authorization) {
    token = bearerToken(*credentials.authorization);
    if (!token) {
      throw ProblemError(unauthorized(
          "The Authorization header is not \"Bearer <token>\" with the token POST /v1/sessions "
          "returned."));
    }
  } else if (allowQueryToken && credentials.queryToken) {
    token = *credentials.queryToken;
  }
  if (!token) {
    throw ProblemError(unauthorized(
        allowQueryToken
            ? "This route needs the session's token: Authorization: Bearer <token> or ?token=."
            : "This route needs the session's token: Authorization: Bearer <token>."));
  }
  // Tokens are compared by their SHA-256: viewer tokens are only kept that way, and a session
  // restored by a viewer never saw its owner's token.
  const std::string hash = sha256Hex(*token);

  SessionPtr session;
  bool otherSession = false;
  {
    std::lock_guard lock(mutex_);
    auto it = sessions_.find(id);
    if (it != sessions_.end()) session = it->second;
    // Every open session's token is compared, so the time taken does not tell which matched.
    for (const auto& [otherId, other] : sessions_) {
      if (other == session) continue;
      bool matches = constantTimeEquals(other->tokenHash, hash);
      {
        std::lock_guard otherLock(other->mutex);
        for (const ViewerToken& viewer : other->viewerTokens) {
          if (constantTimeEquals(viewer.hash, hash)) matches = true;
        }
      }
      if (matches) otherSession = true;
    }
  }
  if (session) {
    bool restoring = false;
    {
      std::lock_guard lock(session->mutex);
      restoring = session->restoring;
    }
    if (restoring) {
      // Another request is restoring it: wait for that (restores hold the id's restore lock).
      RestoreLock waiting(*this, id);
      session = find(id);
    }
  }
  if (session && staleCheck_ && staleCheck_(id)) {
    // Another server wrote (or deleted) this session since: the copy here is out of date.
    std::fprintf(stderr,
                 "myriad-server: session %s is no longer this server's to serve (its lease lapsed "
                 "or moved); reloading it\n",
                 session->id.c_str());
    removeIf(id, session, Session::CloseReason::reloaded);
    session = nullptr;
  }
  if (!session && restorer_) {
    // Not open here: perhaps in the state directory (a restart, another node, idle expiry).
    RestoreLock restoring(*this, id);
    session = find(id);
    if (!session) {
      session = restorer_(id, *token);
      if (session) {
        std::lock_guard lock(session->mutex);
        session->restoring = false;
      }
    }
  }
  if (!session) {
    throw ProblemError(notFoundDetail("There is no session " + quoteClientText(id) +
                                      " (never created, deleted, or expired after " +
                                      std::to_string(idleTimeout_.count()) + " s idle)."));
  }
  Role presented = Role::owner;
  if (!constantTimeEquals(session->tokenHash, hash)) {
    bool viewer = false;
    bool expired = false;
    bool revoked = false;
    {
      std::lock_guard lock(session->mutex);
      const int64_t now = unixNow();
      for (const ViewerToken& v : session->viewerTokens) {
        if (!constantTimeEquals(v.hash, hash)) continue;
        (v.expiresAtUnix > now ? viewer : expired) = true;
      }
      for (const std::string& gone : session->revokedViewerHashes) {
        if (constantTimeEquals(gone, hash)) revoked = true;
      }
    }
    if (!viewer) {
      if (revoked) {
        throw ProblemError(unauthorized("The viewer link to " + quoteClientText(id) +
                                        " was revoked; ask the session's owner for a new one."));
      }
      if (expired) {
        throw ProblemError(unauthorized("This viewer token of " + quoteClientText(id) +
                                        " has expired; ask the session's owner for a new one."));
      }
      if (otherSession) {
        throw ProblemError(forbidden("The token belongs to another session, not to " +
                                     quoteClientText(id) + "."));
      }
      throw ProblemError(unauthorized("The token is not the token of any open session."));
    }
    presented = Role::viewer;
    if (needed == Role::owner) {
      throw ProblemError(forbidden(
          "This is a viewer token of " + quoteClientText(id) +
          ": it can read and watch the session but not change it; changes need the token "
          "POST /v1/sessions returned."));
    }
  }
  if (role != nullptr) *role = presented;
  std::lock_guard lock(session->mutex);
  if (session->closed) {
    throw ProblemError(notFoundDetail("The session " + quoteClientText(id) + " was deleted."));
  }
  session->lastUsed = Clock::now();
  return session;
}

bool SessionManager::remove(std::string_view id, Session::CloseReason reason) {
  return removeIf(id, nullptr, reason);
}

bool SessionManager::removeIf(std::string_view id, const SessionPtr& expected,
                              Session::CloseReason reason) {
  SessionPtr session;
  {
    std::lock_guard lock(mutex_);
    auto it = sessions_.find(id);
    if (it == sessions_.end()) return false;
    if (expected && it->second != expected) return false;
    session = it->second;
    sessions_.erase(it);
  }
  {
    std::lock_guard lock(session->mutex);
    session->closed = true;
    session->closedBecause = reason;
    session->changed.notify_all();
  }
  if (release_) release_(*session);
  if (onClosed_) onClosed_(*session);
  return true;
}

void SessionManager::closeAll() {
  std::vector<std::string> ids;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, session] : sessions_) ids.push_back(id);
  }
  for (const std::string& id : ids) remove(id, Session::CloseReason::shutdown);
}

size_t SessionManager::count() const {
  std::lock_guard lock(mutex_);
  return sessions_.size();
}

int64_t SessionManager::expiresInSeconds(const Session& session) const {
  // Callers hold session.mutex or accept a value a moment stale.
  auto left = idleTimeout_ - std::chrono::duration_cast<std::chrono::seconds>(Clock::now() -
                                                                              session.lastUsed);
  return std::max<int64_t>(0, left.count());
}

size_t SessionManager::sweepExpired() {
  std::vector<std::string> expired;
  const Clock::time_point now = Clock::now();
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, session] : sessions_) {
      std::lock_guard sessionLock(session->mutex);
      // A session without a scene is still being created (its creator holds it; loading a
      // library model may take longer than a short timeout).
      if (session->sceneId == 0) continue;
      if (now - session->lastUsed > idleTimeout_) expired.push_back(id);
    }
  }
  size_t removed = 0;
  for (const std::string& id : expired) {
    if (remove(id, Session::CloseReason::expired)) {
      std::fprintf(stderr, "myriad-server: session %s expired after %lld s idle\n", id.c_str(),
                   static_cast<long long>(idleTimeout_.count()));
      ++removed;
    }
  }
  return removed;
}

void SessionManager::sweeperLoop() {
  // A quarter second keeps expiry within a second of the timeout and costs nothing when idle.
  constexpr auto kPeriod = std::chrono::milliseconds(250);
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    sweeperWake_.wait_for(lock, kPeriod, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    sweepExpired();
    lock.lock();
  }
}

}  // namespace myriad::service
