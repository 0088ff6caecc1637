// Sessions: one client's scene (SessionScene: model, camera, settings, materials, lights) held on
// the CPU, with a GPU scene of its own on the render thread. HTTP workers read and edit a session under its
// mutex; every edit bumps `version` and notifies `changed`, which is what streams wait on.
//
// Locking order: SessionManager's mutex, then a Session's mutex, never the reverse. A worker that
// edits lights holds the session's mutex while it hands the change to the render thread, so the
// render thread sees a session's edits in the order the CPU copy took them (swap-removes depend
// on it).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "service/problem.h"
#include "service/session_scene.h"
#include "service/state_store.h"

namespace myriad::service {

// What a token lets its holder do: the owner's (POST /v1/sessions) everything, a viewer's
// (POST .../tokens) only GET: read the session, watch its frames and stream.
enum class Role { owner, viewer };

// A viewer token as the server keeps it: its SHA-256 and when it stops working (seconds since
// the Unix epoch: a wall-clock time, so that it means the same after a restart).
struct ViewerToken {
  std::string hash;
  int64_t expiresAtUnix = 0;
};

// Seconds since the Unix epoch now (viewer tokens' expiry).
int64_t unixNow();

struct Session {
  // Without `scene`: an empty scene that may hold no lights (tests of what does not need one).
  Session(std::string id, std::string token, SessionScene scene = SessionScene(0, {}));
  // A session restored from the state directory knows its owner token's hash, and the token
  // itself only when the request that restored it carried it (empty otherwise).
  Session(std::string id, std::string token, std::string tokenHash, SessionScene scene);
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  const std::string id;         // "s-" + 16 hex digits
  const std::string token;      // 64 hex digits (32 random bytes); what POST /v1/sessions returns
  const std::string tokenHash;  // sha256Hex(token): what requests are checked against

  // Guards everything below. Never held while waiting for a frame.
  mutable std::mutex mutex;
  // Notified (notify_all) on every version bump and on close.
  std::condition_variable changed;

  uint64_t sceneId = 0;  // the render thread's scene of this session; 0 until it has one
  // The CPU scene: model, materials, camera, settings, lights. Only its methods change it; each
  // returns the GPU change to queue, which the caller queues before unlocking `mutex`.
  SessionScene scene;

  // Viewer tokens (POST .../tokens), by hash; at most protocol::kMaxViewerTokens, expired ones
  // dropped whenever one is added. `tokensChanged` tells the state persister to write them.
  std::vector<ViewerToken> viewerTokens;
  // Hashes of the viewer tokens DELETE .../tokens revoked (the latest kMaxViewerTokens, in memory
  // only): their 401 says "revoked", not just "not a token", so a viewer's page can tell its user.
  std::vector<std::string> revokedViewerHashes;

  // Being restored from the state store (createWithIdentity until its restorer returns): a
  // request that finds it waits for the restore rather than use a half-made session.
  bool restoring = false;

  // Event streams open on it (GET .../events; at most kMaxEventStreamsPerSession).
  uint32_t eventStreams = 0;

  // Bumped (under `mutex`) on every change that can alter a frame; streams compare it.
  uint64_t version = 0;
  // The version of the last change its client said ends an interaction (X-Myriad-Interaction:
  // end): an interactive stream sends the still for it without waiting to see changes stop.
  uint64_t interactionEndVersion = 0;
  // Set when the session is deleted, expired or the server stops; streams end when they see it,
  // and an image stream's last part says why (`closedBecause`).
  enum class CloseReason { deleted, expired, reloaded, shutdown };
  bool closed = false;
  CloseReason closedBecause = CloseReason::deleted;

  // With --state-dir: what the state file needs beyond the snapshot (the bytes behind an uploaded
  // model or environment) and the version last written (StatePersister writes when it moved).
  struct Persisted {
    std::optional<StoredUpload> model;
    // Uploaded assets (POST .../assets) by asset id; a write keeps those the scene still holds.
    std::map<std::string, StoredUpload> assets;
    std::optional<std::string> environmentBlob;
    uint64_t savedVersion = UINT64_MAX;
    bool tokensChanged = false;  // viewer tokens added or revoked since the last write
    // The session's lease (lease.h): the epoch this copy is served under; 0 until it has one.
    // `fresh`: created here (POST /v1/sessions), so its first write takes a new lease; a restored
    // copy gets the epoch its restore took. `storedVersion`: the highest version the store
    // confirmed (-1: none yet), which an edit's response waits for (session_sync.h).
    uint64_t epoch = 0;
    bool fresh = false;
    int64_t storedVersion = -1;
  };
  Persisted persisted;

  Clock::time_point created = Clock::now();
  Clock::time_point lastUsed = Clock::now();  // refreshed by every authorized request

  // With `mutex` held: records a change and wakes whoever waits on `changed`.
  void bump(bool endsInteraction = false) {
    ++version;
    if (endsInteraction) interactionEndVersion = version;
    changed.notify_all();
  }

  // Blocks until version differs from `seen`, the session closes, or `deadline`. Returns the
  // version then (unchanged on timeout). For streams: take a snapshot, render, wait here.
  uint64_t waitForChange(uint64_t seen, Clock::time_point deadline) {
    std::unique_lock lock(mutex);
    changed.wait_until(lock, deadline, [&] { return version != seen || closed; });
    return version;
  }
};

using SessionPtr = std::shared_ptr<Session>;

// Client-supplied credentials of one request: the Authorization header and the ?token= query
// parameter (accepted by frame and stream only; the header wins when both are present).
struct Credentials {
  std::optional<std::string> authorization;  // the whole header value, "Bearer <token>"
  std::optional<std::string> queryToken;
};

class SessionManager {
 public:
  // Releases a session's GPU scene; runs on the caller's thread and returns once the render
  // thread has destroyed the scene (so DELETE answers after the memory is free).
  using SceneReleaser = std::function<void(Session&)>;

  SessionManager(uint32_t maxSessions, std::chrono::seconds idleTimeout, SceneReleaser release);
  ~SessionManager();  // stops the sweeper; closes (and releases) every session left
  SessionManager(const SessionManager&) = delete;
  SessionManager& operator=(const SessionManager&) = delete;

  // A new session with a fresh id and token, holding `scene` but no GPU scene yet (the caller
  // creates one, adopts the model into `scene` and sets sceneId before returning it). Throws
  // ProblemError 429 limit maxSessions when `maxSessions` are open.
  SessionPtr create(SessionScene scene = SessionScene(0, {}));
  // A session with a given id and token (one restored from the state directory). Also 429 at
  // maxSessions; 409-free: the caller checked that `id` is not open (under restoring()).
  // `token` is the presented token when it is the owner's, else "" (restored by a viewer).
  SessionPtr createWithIdentity(std::string id, std::string token, std::string tokenHash,
                                SessionScene scene);

  // Every open session (the state persister walks them).
  std::vector<SessionPtr> all() const;

  // With --state-dir: how a session that is not open is looked for, given a token. Returns the
  // restored session (now open), or null when there is nothing to restore; throws ProblemError
  // (403 for a token that does not match the stored hash, 422 for a model that no longer loads).
  // Called by authorize() with no lock held, one restore of an id at a time.
  using Restorer = std::function<SessionPtr(std::string_view id, const std::string& token)>;
  void setRestorer(Restorer restorer) { restorer_ = std::move(restorer); }

  // With a state store: whether an open session's copy here may no longer be served (its lease
  // lapsed or went to another node). authorize() then closes the stale copy here and restores
  // the session from the store (or answers 404 when it is gone, 409 naming its owner).
  using StaleCheck = std::function<bool(std::string_view id)>;
  void setStaleCheck(StaleCheck check) { staleCheck_ = std::move(check); }
  // Told of every session closed here, after its GPU scene is released (its lease is given back).
  // Set before serving, like the restorer.
  using Closed = std::function<void(const Session&)>;
  void setOnClosed(Closed closed) { onClosed_ = std::move(closed); }

  // --node-id: new session ids start with the node's number as 2 hex digits ("s-" + 2 + 14 random
  // hex digits), which the front routes by.
  void setNode(uint32_t node);

  // The open session with this id, or null.
  SessionPtr find(std::string_view id) const;

  // The session `id` if `credentials` carry its token. Problems: 401 (no or malformed bearer
  // token, or one that belongs to no session), 404 (no such session: never created, deleted or
  // expired), 403 (the token of another session). Tokens are compared in constant time. Refreshes
  // the session's idle timer. Throws ProblemError.
  //
  // A viewer token of the session (not expired) passes when `needed` is Role::viewer, and is 403
  // otherwise (a change needs the owner's token); an expired one is 401. `role`, when given,
  // receives the role of the token presented.
  SessionPtr authorize(std::string_view id, const Credentials& credentials,
                       bool allowQueryToken = false, Role needed = Role::owner,
                       Role* role = nullptr);

  // Closes the session (streams wake and end, told `reason`), releases its GPU scene and forgets
  // it. False when there was no such session.
  bool remove(std::string_view id, Session::CloseReason reason = Session::CloseReason::deleted);
  // remove(), only while `id` is still `expected` (not a copy restored since).
  bool removeIf(std::string_view id, const SessionPtr& expected,
                Session::CloseReason reason = Session::CloseReason::deleted);

  // Closes every session (server shutdown): streams end; GPU scenes are released.
  void closeAll();

  size_t count() const;
  uint32_t maxSessions() const { return maxSessions_; }
  std::chrono::seconds idleTimeout() const { return idleTimeout_; }

  // Seconds until `session` expires if left alone (what responses report as expiresInSeconds).
  int64_t expiresInSeconds(const Session& session) const;

  // Removes sessions idle for longer than the timeout; returns how many. The sweeper thread calls
  // this about once a second; tests and handlers may call it too.
  size_t sweepExpired();

 private:
  void sweeperLoop();

  const uint32_t maxSessions_;
  const std::chrono::seconds idleTimeout_;
  const SceneReleaser release_;
  Restorer restorer_;
  StaleCheck staleCheck_;
  Closed onClosed_;
  std::string nodeHex_;  // "" without --node-id
  // One restore of an id at a time (two requests may race for one id); restores of different ids
  // run side by side, so that one waiting for a lease (session_sync.h) holds up no other.
  class RestoreLock;
  std::mutex restoreLocksMutex_;
  std::map<std::string, std::shared_ptr<std::mutex>, std::less<>> restoreLocks_;

  mutable std::mutex mutex_;
  std::map<std::string, SessionPtr, std::less<>> sessions_;
  std::condition_variable sweeperWake_;
  bool stopping_ = false;
  std::thread sweeper_;
};

// Constant-time equality of two strings of equal length (false, quickly, when lengths differ:
// every token has the same length, so that reveals nothing).
bool constantTimeEquals(std::string_view a, std::string_view b);

// A new token: 32 bytes from the kernel's CSPRNG, as 64 hex digits.
std::string randomToken();

// "Bearer <64 hex>" -> the token; nullopt when the header is missing or malformed.
std::optional<std::string> bearerToken(std::string_view authorization);

}  // namespace myriad::service
