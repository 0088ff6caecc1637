// Sessions kept in a state store (--state-dir or --state-store): what HttpServer runs for them.
//
// - Writes: every session whose version moved is written (StatePersister), under the lease epoch
//   its copy was made with. A successful edit is written before its response: confirmEdit(),
//   from the post-routing handler, flushes and checks that the version the response names (its
//   ETag) is stored; when it is not, the response becomes a problem instead of a 2xx - 409
//   naming the owner when the store refused the write (another node owns the session now; the
//   copy here is closed), 503 when the store could not be reached (the copy is closed too, so
//   that nothing unstored is served: the session reloads from the store). So a 2xx edit is in
//   the store, and an edit answered 409 never is.
// - Leases (lease.h): a session is created or restored here only with its lease; a copy whose
//   lease lapsed or went to another node is closed before it serves a request, and the request
//   restores the session (taking the lease) or is answered 409 naming the owner.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include <httplib.h>

#include "service/api.h"
#include "service/lease.h"
#include "service/session.h"
#include "service/state_store.h"

namespace myriad::service {

class SessionSync {
 public:
  // Installs the restorer and the stale check on `sessions`. `node`: the lease owner this server
  // writes as (--node-id, else one made from the process id).
  SessionSync(SessionManager& sessions, ApiContext& api, StateStore& store, uint32_t node,
              std::chrono::milliseconds leaseTime, std::chrono::seconds retention);
  ~SessionSync();  // flushes, stops writing, gives back the leases
  SessionSync(const SessionSync&) = delete;
  SessionSync& operator=(const SessionSync&) = delete;

  // Writes what changed now.
  void flush();
  // After a handler: for a 2xx edit of a session, its change is stored or the response says why
  // not (see above). Adds X-Myriad-Owner to a 409 that names the owner.
  void confirmEdit(const httplib::Request& req, httplib::Response& res);
  // A session closed here (deleted, expired, lost, shut down): its lease is given back.
  void closed(const Session& session);
  // The lease series for /metrics.
  std::string exposition(std::string_view labels) const { return leases_.exposition(labels); }

 private:
  std::vector<StoredSession> collect();
  void written(const StoredSession& stored, const WriteResult& result);
  SessionPtr restore(std::string_view id, const std::string& token);
  bool stale(std::string_view id);

  SessionManager& sessions_;
  ApiContext& api_;
  StateStore& store_;
  LeaseKeeper leases_;
  std::mutex outcomesMutex_;
  // The last write of each session that did not store it, until one does (confirmEdit's reason).
  std::map<std::string, WriteResult, std::less<>> failures_;
  std::unique_ptr<StatePersister> persister_;  // last: stopped (flushing) first
};

}  // namespace myriad::service
