#include "service/session_sync.h"

#include <cstdio>
#include <cstdlib>
#include <regex>

#include "protocol/constants.h"
#include "service/problem.h"

namespace myriad::service {

namespace {

// The session a request path names ("/v1/sessions/s-.../..."), and whether it is the session
// itself (no further segment).
struct PathSession {
  std::string id;
  bool whole = false;
};

std::optional<PathSession> sessionOfPath(std::string_view path) {
  static const std::regex pattern("^/v1/sessions/(s-[0-9a-f]{16})(/.*)?$");
  std::match_results<std::string_view::const_iterator> m;
  if (!std::regex_match(path.begin(), path.end(), m, pattern)) return std::nullopt;
  return PathSession{m[1].str(), !m[2].matched || m[2].length() <= 1};
}

// The version an ETag ("12-4f3a9c01") names; nullopt for anything else.
std::optional<uint64_t> versionOfTag(const std::string& tag) {
  if (tag.size() < 3 || tag.front() != '"') return std::nullopt;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(tag.c_str() + 1, &end, 10);
  if (end == tag.c_str() + 1 || *end != '-') return std::nullopt;
  return uint64_t(v);
}

}  // namespace

SessionSync::SessionSync(SessionManager& sessions, ApiContext& api, StateStore& store,
                         uint32_t node, std::chrono::milliseconds leaseTime,
                         std::chrono::seconds retention)
    : sessions_(sessions),
      api_(api),
      store_(store),
      leases_(store, node, leaseTime, [this](const std::string& id, uint64_t epoch) {
        if (SessionPtr s = sessions_.find(id)) {
          bool same = false;
          {
            std::lock_guard lock(s->mutex);
            same = s->persisted.epoch == epoch;
          }
          if (same) sessions_.removeIf(id, s, Session::CloseReason::reloaded);
        }
      }) {
  // Every successful edit is written before its response (confirmEdit); this pass every 250 ms
  // catches changes no request made.
  persister_ = std::make_unique<StatePersister>(
      store, node, [this] { return collect(); },
      [this](const StoredSession& s, const WriteResult& r) { written(s, r); },
      std::chrono::milliseconds(250), retention);
  sessions_.setRestorer(
      [this](std::string_view id, const std::string& token) { return restore(id, token); });
  sessions_.setStaleCheck([this](std::string_view id) { return stale(id); });
  sessions_.setOnClosed([this](const Session& session) { closed(session); });
}

SessionSync::~SessionSync() {
  persister_.reset();
  sessions_.setRestorer(nullptr);
  sessions_.setStaleCheck(nullptr);
  sessions_.setOnClosed(nullptr);
}

void SessionSync::flush() { persister_->flush(); }

std::vector<StoredSession> SessionSync::collect() {
  std::vector<StoredSession> changed;
  for (const SessionPtr& session : sessions_.all()) {
    // A session just created takes its lease before its first write (a store call: not under
    // the session's lock).
    bool needsLease = false;
    {
      std::lock_guard lock(session->mutex);
      needsLease = session->persisted.fresh && session->persisted.epoch == 0 &&
                   !session->closed && session->sceneId != 0;
    }
    uint64_t epoch = 0;
    if (needsLease) {
      try {
        epoch = leases_.acquire(session->id, true);
      } catch (const ProblemError& e) {
        std::fprintf(stderr, "myriad-server: session %s: no lease: %s\n", session->id.c_str(),
                     e.what());
        std::lock_guard lock(outcomesMutex_);
        failures_[session->id] = {WriteOutcome::failed, 0, e.what()};
        continue;
      }
    }
    std::lock_guard lock(session->mutex);
    if (epoch != 0) session->persisted.epoch = epoch;
    // A session still being created has no GPU scene yet; a closed one is gone (or going); one
    // being restored has no lease epoch yet.
    if (session->closed || session->sceneId == 0 || session->persisted.epoch == 0) continue;
    if (session->version == session->persisted.savedVersion &&
        !session->persisted.tokensChanged) {
      continue;
    }
    StoredSession stored;
    stored.id = session->id;
    stored.version = session->version;
    stored.epoch = session->persisted.epoch;
    stored.tokenHash = session->tokenHash;
    for (const ViewerToken& v : session->viewerTokens) {
      stored.viewers.push_back({v.hash, v.expiresAtUnix});
    }
    session->persisted.tokensChanged = false;
    stored.snapshot = session->scene.snapshot();
    stored.model = session->persisted.model;
    // The uploads behind the scene's uploaded assets but the model's (those deleted since are
    // forgotten here).
    std::map<std::string, StoredUpload>& uploads = session->persisted.assets;
    const SceneGraph& graph = session->scene.graph();
    std::erase_if(uploads, [&](const auto& entry) { return !graph.findAsset(entry.first); });
    for (const auto& [assetId, upload] : uploads) {
      if (!stored.model || assetIdOfBlob(stored.model->blob) != assetId) {
        stored.assets.push_back(upload);
      }
    }
    stored.environmentBlob = session->persisted.environmentBlob;
    stored.lightIds = session->scene.lightIds();
    stored.nextLightId = session->scene.nextLightId();
    session->persisted.savedVersion = session->version;
    changed.push_back(std::move(stored));
  }
  return changed;
}

void SessionSync::written(const StoredSession& stored, const WriteResult& result) {
  {
    std::lock_guard lock(outcomesMutex_);
    if (result.outcome == WriteOutcome::written) {
      failures_.erase(stored.id);
    } else {
      failures_[stored.id] = result;
    }
  }
  SessionPtr session = sessions_.find(stored.id);
  if (!session) return;
  {
    std::lock_guard lock(session->mutex);
    if (session->persisted.epoch != stored.epoch) return;  // a copy made since
    if (result.outcome == WriteOutcome::written) {
      session->persisted.storedVersion =
          std::max<int64_t>(session->persisted.storedVersion, int64_t(stored.version));
      return;
    }
    if (result.outcome == WriteOutcome::failed) {
      ++leases_.failedWrites;
      session->persisted.savedVersion = UINT64_MAX;  // written again next time
      return;
    }
  }
  // Fenced, stale or deleted elsewhere: this copy is not the session any more.
  ++leases_.fencedWrites;
  std::fprintf(stderr,
               "myriad-server: session %s: write refused by the store (%s%s); copy closed\n",
               stored.id.c_str(),
               result.outcome == WriteOutcome::fenced ? "its lease is node "
               : result.outcome == WriteOutcome::stale ? "a later version is stored"
                                                       : "deleted",
               result.outcome == WriteOutcome::fenced ? std::to_string(result.owner).c_str() : "");
  leases_.dropped(stored.id, stored.epoch);
  sessions_.removeIf(stored.id, session, Session::CloseReason::reloaded);
}

void SessionSync::confirmEdit(const httplib::Request& req, httplib::Response& res) {
  if (std::optional<uint32_t> owner = takeOwnerHint(); owner && res.status == 409) {
    res.set_header("X-Myriad-Owner", std::to_string(*owner));
  }
  if (res.status < 200 || res.status >= 300 || req.method == "GET" || req.method == "HEAD" ||
      req.method == "OPTIONS") {
    return;
  }
  std::optional<PathSession> named = sessionOfPath(req.path);
  if (!named && req.method == "POST" && req.path == protocol::routes::kSessions) {
    named = sessionOfPath(res.get_header_value(std::string(protocol::headers::kLocation)));
  }
  if (!named) return;
  if (named->whole && req.method == "DELETE") return;  // deleted: forget() said so
  // The version this response acknowledges: its ETag's, else the session's now (taken before the
  // flush, so that a later request's edit is not waited for).
  const std::string tag = res.get_header_value(std::string(protocol::headers::kETag));
  SessionPtr session = sessions_.find(named->id);
  std::optional<uint64_t> version = versionOfTag(tag);
  if (session && !version) {
    std::lock_guard lock(session->mutex);
    version = session->version;
  }
  flush();
  bool stored = false;
  uint64_t epoch = 0;
  if (session && version) {
    std::lock_guard lock(session->mutex);
    // Stored is stored, even if the copy has closed since (a shutdown, a lease lost after).
    stored = session->persisted.storedVersion >= int64_t(*version);
    epoch = session->persisted.epoch;
  }
  if (stored) return;
  WriteResult why{WriteOutcome::failed, 0, "the session was closed here"};
  {
    std::lock_guard lock(outcomesMutex_);
    if (auto it = failures_.find(named->id); it != failures_.end()) why = it->second;
  }
  // Nothing unstored is served: the copy goes, and the session reloads from the store.
  if (session) {
    leases_.dropped(named->id, epoch);
    sessions_.removeIf(named->id, session, Session::CloseReason::reloaded);
  }
  // The 2xx is replaced whole: its length (set already) and what named the change.
  res.headers.erase("Content-Length");
  res.headers.erase(std::string(protocol::headers::kETag));
  res.headers.erase(std::string(protocol::headers::kLocation));
  Problem problem;
  if (why.outcome == WriteOutcome::fenced || why.outcome == WriteOutcome::stale) {
    problem = conflict("The change to " + named->id +
                       " was not made: the session is served by node " +
                       std::to_string(why.owner) +
                       " now (this node's lease lapsed); send its requests there.");
    res.set_header("X-Myriad-Owner", std::to_string(why.owner));
  } else if (why.outcome == WriteOutcome::gone) {
    problem = notFoundDetail("The session " + named->id + " was deleted.");
  } else {
    problem = serverBusy("The change to " + named->id + " could not be stored in " +
                         store_.describe() + " (" + why.detail +
                         "); it may not have been made. Read the session and retry.");
    problem.retryAfterSeconds = 1;
  }
  sendProblem(res, problem);
}

void SessionSync::closed(const Session& session) {
  uint64_t epoch = 0;
  {
    std::lock_guard lock(session.mutex);
    epoch = session.persisted.epoch;
  }
  if (epoch != 0) leases_.release(session.id, epoch);
}

SessionPtr SessionSync::restore(std::string_view id, const std::string& token) {
  // The token is checked against the record before the lease is taken: a request without the
  // session's token must not move its lease.
  std::optional<StoredSession> before;
  try {
    before = store_.load(id);
  } catch (const StoreUnavailable& e) {
    Problem problem = serverBusy("The session store (" + store_.describe() +
                                 ") cannot be reached: " + e.what() + ". Retry shortly.");
    problem.retryAfterSeconds = 1;
    throw ProblemError(problem);
  }
  if (!before) return nullptr;
  const std::string hash = sha256Hex(token);
  bool known = constantTimeEquals(hash, before->tokenHash);
  for (const StoredSession::Viewer& v : before->viewers) {
    if (constantTimeEquals(hash, v.tokenHash)) known = true;
  }
  if (!known) {
    throw ProblemError(forbidden("The token is not the token of the session " +
                                 quoteClientText(id) + "."));
  }
  const uint64_t epoch = leases_.acquire(id, false);
  SessionPtr session;
  try {
    session = restoreStoredSession(api_, id, token);
  } catch (...) {
    leases_.release(id, epoch);
    throw;
  }
  if (!session) {
    leases_.release(id, epoch);
    return nullptr;
  }
  bool ours = false;
  {
    std::lock_guard lock(session->mutex);
    ours = session->persisted.epoch == epoch;
  }
  if (!ours) {
    // Taken over between the lease and the read: not ours to serve.
    sessions_.removeIf(session->id, session, Session::CloseReason::reloaded);
    throw ProblemError(conflict("The session " + quoteClientText(id) +
                                " moved to another node while it was restored here; retry."));
  }
  if (epoch > 1) ++leases_.takeovers;
  return session;
}

bool SessionSync::stale(std::string_view id) {
  SessionPtr session = sessions_.find(id);
  if (!session) return false;
  uint64_t epoch = 0;
  {
    std::lock_guard lock(session->mutex);
    // Being created (no lease yet) or being restored (the restore set it): not stale.
    if (session->persisted.epoch == 0) return false;
    epoch = session->persisted.epoch;
  }
  return !leases_.holds(id, epoch);
}

}  // namespace myriad::service
