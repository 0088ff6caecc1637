#include "service/store_postgres.h"

#include <libpq-fe.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <stdexcept>

namespace myriad::service {

namespace {

using ResultPtr = std::unique_ptr<PGresult, decltype(&PQclear)>;

// One statement's parameter: text, or bytes sent as binary (a blob).
struct Param {
  std::string value;
  bool binary = false;
};

// The first line of libpq's message (they end in a newline, some run to several lines).
std::string firstLine(const char* message) {
  std::string text = message != nullptr ? message : "";
  if (size_t end = text.find('\n'); end != std::string::npos) text.resize(end);
  return text.empty() ? "no reason given" : text;
}

constexpr const char* kSchema = R"sql(
BEGIN;
SELECT pg_advisory_xact_lock(20261205033);
CREATE TABLE IF NOT EXISTS myriad_sessions (
  id text PRIMARY KEY,
  version bigint NOT NULL,
  record text NOT NULL,
  blobs text[] NOT NULL DEFAULT '{}',
  updated_at timestamptz NOT NULL DEFAULT now());
CREATE TABLE IF NOT EXISTS myriad_leases (
  session_id text PRIMARY KEY,
  owner integer NOT NULL,
  epoch bigint NOT NULL,
  expires_at timestamptz NOT NULL,
  deleted boolean NOT NULL DEFAULT false,
  wanted_by integer);
ALTER TABLE myriad_leases ADD COLUMN IF NOT EXISTS wanted_by integer;
CREATE TABLE IF NOT EXISTS myriad_blobs (
  key text PRIMARY KEY,
  bytes bytea NOT NULL,
  created_at timestamptz NOT NULL DEFAULT now());
COMMIT;
)sql";

// A PostgreSQL text array of session ids (which hold only [s0-9a-f-]: nothing to quote).
std::string textArray(const std::vector<std::string>& items) {
  std::string out = "{";
  for (size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += ',';
    out += items[i];
  }
  return out + "}";
}

}  // namespace

// Connections, one per statement in flight: taken, used, given back; a broken one is dropped.
class PostgresStateStore::Pool {
 public:
  explicit Pool(std::string conninfo) : conninfo_(std::move(conninfo)) {}
  ~Pool() {
    for (PGconn* c : idle_) PQfinish(c);
  }

  PGconn* connect() const {
    // Earlier keywords are defaults the connection string may override. A server stopped
    // (SIGSTOP) inside a statement holds its locks at most this long.
    const char* keywords[] = {"connect_timeout", "options", "application_name", "dbname", nullptr};
    const char* values[] = {"3",
                            "-c statement_timeout=5000 -c lock_timeout=4000 "
                            "-c idle_in_transaction_session_timeout=2000 "
                            "-c client_min_messages=warning",
                            "myriad-server", conninfo_.c_str(), nullptr};
    PGconn* c = PQconnectdbParams(keywords, values, 1);
    if (c == nullptr || PQstatus(c) != CONNECTION_OK) {
      const std::string why = firstLine(c != nullptr ? PQerrorMessage(c) : "out of memory");
      if (c != nullptr) PQfinish(c);
      throw StoreUnavailable("PostgreSQL cannot be reached: " + why);
    }
    return c;
  }

  // Runs one statement. A pooled connection the database dropped meanwhile (a restart, an
  // administrator, idle_in_transaction_session_timeout) fails at once: the statement is run
  // again, once, on a new connection (every statement here may run twice: saves and renewals are
  // idempotent, an acquire twice only takes its own lease again).
  ResultPtr exec(const char* sql, const std::vector<Param>& params, int resultFormat = 0) {
    bool reused = false;
    PGconn* c = take(&reused);
    if (reused) {
      bool broken = false;
      try {
        return run(c, sql, params, resultFormat, &broken);
      } catch (const StoreUnavailable&) {
        if (!broken) throw;
      }
      c = connect();
    }
    bool broken = false;
    return run(c, sql, params, resultFormat, &broken);
  }

 private:
  // Runs `sql` on `c` and gives `c` back (or drops it, setting `broken`, when it broke).
  ResultPtr run(PGconn* c, const char* sql, const std::vector<Param>& params, int resultFormat,
                bool* broken) {
    std::vector<const char*> values;
    std::vector<int> lengths;
    std::vector<int> formats;
    for (const Param& p : params) {
      values.push_back(p.value.data());
      lengths.push_back(int(p.value.size()));
      formats.push_back(p.binary ? 1 : 0);
    }
    ResultPtr result(PQexecParams(c, sql, int(params.size()), nullptr, values.data(),
                                  lengths.data(), formats.data(), resultFormat),
                     &PQclear);
    const ExecStatusType status = result ? PQresultStatus(result.get()) : PGRES_FATAL_ERROR;
    if (status != PGRES_TUPLES_OK && status != PGRES_COMMAND_OK) {
      const std::string why = firstLine(result ? PQresultErrorMessage(result.get())
                                               : PQerrorMessage(c));
      *broken = PQstatus(c) != CONNECTION_OK;
      giveBack(c);
      throw StoreUnavailable("PostgreSQL refused a statement: " + why);
    }
    giveBack(c);
    return result;
  }

  PGconn* take(bool* reused) {
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        PGconn* c = idle_.back();
        idle_.pop_back();
        *reused = true;
        return c;
      }
    }
    *reused = false;
    return connect();
  }
  void giveBack(PGconn* c) {
    // A connection that broke (the server restarted, the network went) is not used again.
    if (PQstatus(c) != CONNECTION_OK || PQtransactionStatus(c) != PQTRANS_IDLE) {
      PQfinish(c);
      return;
    }
    std::lock_guard lock(mutex_);
    idle_.push_back(c);
  }

  const std::string conninfo_;
  std::mutex mutex_;
  std::vector<PGconn*> idle_;
};

PostgresStateStore::PostgresStateStore(std::string conninfo, StateLimits limits)
    : pool_(std::make_unique<Pool>(std::move(conninfo))), limits_(limits) {
  PGconn* c = nullptr;
  try {
    c = pool_->connect();
  } catch (const StoreUnavailable& e) {
    throw std::runtime_error(std::string("The state store: ") + e.what() + ".");
  }
  const char* host = PQhost(c);
  description_ = std::string("the PostgreSQL database ") + PQdb(c) + " on " +
                 (host != nullptr ? host : "localhost") + ":" + PQport(c);
  ResultPtr made(PQexec(c, kSchema), &PQclear);
  const bool ok = made && PQresultStatus(made.get()) == PGRES_COMMAND_OK;
  const std::string why = ok ? "" : firstLine(PQerrorMessage(c));
  PQfinish(c);
  if (!ok) {
    throw std::runtime_error("The state store's tables cannot be made in " + description_ + ": " +
                             why + ".");
  }
}

PostgresStateStore::~PostgresStateStore() = default;

std::string PostgresStateStore::putBlob(std::string_view bytes) {
  const std::string key = sha256Hex(bytes);
  // Renewed when already there, so that a sweep does not remove it before a record names it.
  pool_->exec(
      "INSERT INTO myriad_blobs (key, bytes) VALUES ($1, $2) "
      "ON CONFLICT (key) DO UPDATE SET created_at = now()",
      {{key}, {std::string(bytes), true}});
  return key;
}

std::optional<std::string> PostgresStateStore::blob(std::string_view key, std::string* why) const {
  if (!isHexKey(key)) {
    if (why) *why = "not a blob key";
    return std::nullopt;
  }
  ResultPtr r(nullptr, &PQclear);
  try {
    r = pool_->exec(
        "SELECT CASE WHEN octet_length(bytes) <= $2::bigint THEN bytes END, octet_length(bytes) "
        "FROM myriad_blobs WHERE key = $1",
        {{std::string(key)}, {std::to_string(limits_.blobBytes)}}, 1);
  } catch (const StoreUnavailable& e) {
    if (why) *why = e.what();
    return std::nullopt;
  }
  if (PQntuples(r.get()) == 0) {
    if (why) *why = "it is missing";
    return std::nullopt;
  }
  if (PQgetisnull(r.get(), 0, 0)) {
    if (why) *why = "it is over the limit of " + std::to_string(limits_.blobBytes) + " bytes";
    return std::nullopt;
  }
  std::string bytes(PQgetvalue(r.get(), 0, 0), size_t(PQgetlength(r.get(), 0, 0)));
  // A blob is named by its hash: a damaged one is as good as missing.
  if (sha256Hex(bytes) != key) {
    if (why) *why = "its bytes are not the ones its key hashes";
    return std::nullopt;
  }
  if (why) why->clear();
  return bytes;
}

WriteResult PostgresStateStore::save(const StoredSession& session, uint32_t node) {
  if (!isSessionId(session.id)) throw std::invalid_argument("not a session id: " + session.id);
  const std::string text = recordToJson(session).dump();
  if (text.size() > limits_.recordBytes) {
    throw std::runtime_error("its record has " + std::to_string(text.size()) +
                             " bytes, over the " + std::to_string(limits_.recordBytes) +
                             " a restore reads");
  }
  // One statement: the lease row locked, the record written only under the writer's epoch and
  // never back to a lower version, and what the lease is now to tell why not.
  static constexpr const char* kSave = R"sql(
WITH l AS (
  SELECT owner, epoch, deleted FROM myriad_leases WHERE session_id = $1 FOR UPDATE
), w AS (
  INSERT INTO myriad_sessions AS s (id, version, record, blobs, updated_at)
  SELECT $1, $3::bigint, $4, $5::text[], now() FROM l
   WHERE l.owner = $2::integer AND l.epoch = $6::bigint AND NOT l.deleted
  ON CONFLICT (id) DO UPDATE SET version = EXCLUDED.version, record = EXCLUDED.record,
     blobs = EXCLUDED.blobs, updated_at = now()
   WHERE s.version <= EXCLUDED.version
  RETURNING s.version
)
SELECT l.owner, l.epoch, l.deleted, (SELECT count(*) FROM w) FROM l)sql";
  ResultPtr r(nullptr, &PQclear);
  try {
    r = pool_->exec(kSave, {{session.id},
                            {std::to_string(node)},
                            {std::to_string(session.version)},
                            {text},
                            {textArray(blobKeysOf(session))},
                            {std::to_string(session.epoch)}});
  } catch (const StoreUnavailable& e) {
    return {WriteOutcome::failed, 0, e.what()};
  }
  if (PQntuples(r.get()) == 0) return {WriteOutcome::fenced, 0, "the session has no lease"};
  const uint32_t owner = uint32_t(std::strtoul(PQgetvalue(r.get(), 0, 0), nullptr, 10));
  const uint64_t epoch = std::strtoull(PQgetvalue(r.get(), 0, 1), nullptr, 10);
  const bool deleted = PQgetvalue(r.get(), 0, 2)[0] == 't';
  const bool written = std::strtoull(PQgetvalue(r.get(), 0, 3), nullptr, 10) > 0;
  if (deleted) return {WriteOutcome::gone, 0, ""};
  if (owner != node || epoch != session.epoch) return {WriteOutcome::fenced, owner, ""};
  if (!written) return {WriteOutcome::stale, owner, ""};
  return {};
}

std::optional<StoredSession> PostgresStateStore::load(std::string_view id) const {
  if (!isSessionId(id)) return std::nullopt;
  ResultPtr r = pool_->exec(
      "SELECT CASE WHEN octet_length(s.record) <= $2::bigint THEN s.record END, s.version, "
      "coalesce(l.epoch, 0), octet_length(s.record) FROM myriad_sessions s "
      "LEFT JOIN myriad_leases l ON l.session_id = s.id WHERE s.id = $1",
      {{std::string(id)}, {std::to_string(limits_.recordBytes)}});
  if (PQntuples(r.get()) == 0) return std::nullopt;
  const uint64_t version = std::strtoull(PQgetvalue(r.get(), 0, 1), nullptr, 10);
  {
    std::lock_guard lock(refusedMutex_);
    if (auto it = refused_.find(id); it != refused_.end() && it->second == version) {
      return std::nullopt;
    }
    loadedVersions_[std::string(id)] = version;
  }
  if (PQgetisnull(r.get(), 0, 0)) {
    refuse(id, std::string("its record has ") + PQgetvalue(r.get(), 0, 3) +
                   " bytes, over the limit of " + std::to_string(limits_.recordBytes),
           true);
    return std::nullopt;
  }
  try {
    const nlohmann::json j = nlohmann::json::parse(PQgetvalue(r.get(), 0, 0));
    StoredSession session = recordFromJson(j, limits_);
    if (session.id != id) throw std::runtime_error("/id names another session");
    if (session.version != version) throw std::runtime_error("/version is not the row's version");
    session.epoch = std::strtoull(PQgetvalue(r.get(), 0, 2), nullptr, 10);
    return session;
  } catch (const std::exception& e) {
    refuse(id, e.what(), true);
    return std::nullopt;
  }
}

void PostgresStateStore::refuse(std::string_view id, std::string_view reason,
                                bool remember) const {
  if (remember) {
    std::lock_guard lock(refusedMutex_);
    if (auto it = loadedVersions_.find(id); it != loadedVersions_.end()) {
      refused_[std::string(id)] = it->second;
    }
  }
  std::fprintf(stderr,
               "myriad-server: state: the row of session %.*s in %s refused, its session not "
               "restored: %.*s\n",
               int(id.size()), id.data(), description_.c_str(), int(reason.size()),
               reason.data());
}

bool PostgresStateStore::forget(std::string_view id, uint32_t node, uint64_t epoch) {
  if (!isSessionId(id)) return false;
  // The lease stays, deleted, so that its epochs are never given out again.
  ResultPtr r = pool_->exec(R"sql(
WITH l AS (
  UPDATE myriad_leases SET owner = 0, epoch = epoch + 1, expires_at = now(), deleted = true
   WHERE session_id = $1 AND owner = $2::integer AND epoch = $3::bigint AND NOT deleted
  RETURNING session_id
), d AS (
  DELETE FROM myriad_sessions WHERE id IN (SELECT session_id FROM l)
)
SELECT (SELECT count(*) FROM l)
     + (SELECT count(*) FROM myriad_leases WHERE session_id = $1 AND deleted))sql",
                            {{std::string(id)}, {std::to_string(node)}, {std::to_string(epoch)}});
  return std::strtoull(PQgetvalue(r.get(), 0, 0), nullptr, 10) > 0;
}

LeaseGrant PostgresStateStore::acquire(std::string_view id, uint32_t node,
                                       std::chrono::milliseconds ttl, bool fresh, bool handover) {
  if (!isSessionId(id)) return {};
  const std::string ms = std::to_string(ttl.count());
  ResultPtr r = pool_->exec(R"sql(
INSERT INTO myriad_leases AS l (session_id, owner, epoch, expires_at)
VALUES ($1, $2::integer, 1, now() + $3::bigint * interval '1 millisecond')
ON CONFLICT (session_id) DO UPDATE
   SET owner = EXCLUDED.owner, epoch = l.epoch + 1, expires_at = EXCLUDED.expires_at,
       wanted_by = NULL
 WHERE NOT $4::boolean AND NOT l.deleted AND (l.owner = EXCLUDED.owner OR l.expires_at <= now())
RETURNING owner, epoch)sql",
                            {{std::string(id)}, {std::to_string(node)}, {ms},
                             {fresh ? "true" : "false"}});
  if (PQntuples(r.get()) == 1) {
    return {true, {node, std::strtoull(PQgetvalue(r.get(), 0, 1), nullptr, 10), ttl.count()}};
  }
  if (handover && !fresh) {
    pool_->exec(
        "UPDATE myriad_leases SET wanted_by = $2::integer WHERE session_id = $1 AND NOT deleted "
        "AND owner <> $2::integer AND wanted_by IS DISTINCT FROM $2::integer",
        {{std::string(id)}, {std::to_string(node)}});
  }
  ResultPtr now = pool_->exec(
      "SELECT owner, epoch, deleted, "
      "(extract(epoch FROM expires_at - clock_timestamp()) * 1000)::bigint "
      "FROM myriad_leases WHERE session_id = $1",
      {{std::string(id)}});
  if (PQntuples(now.get()) == 0) return {};
  Lease lease;
  lease.owner = uint32_t(std::strtoul(PQgetvalue(now.get(), 0, 0), nullptr, 10));
  lease.epoch = std::strtoull(PQgetvalue(now.get(), 0, 1), nullptr, 10);
  lease.expiresInMs = std::strtoll(PQgetvalue(now.get(), 0, 3), nullptr, 10);
  if (PQgetvalue(now.get(), 0, 2)[0] == 't') lease = {0, lease.epoch, 0, true};
  return {false, lease};
}

std::vector<std::string> PostgresStateStore::renew(
    uint32_t node, const std::vector<std::pair<std::string, uint64_t>>& held,
    std::chrono::milliseconds ttl, std::vector<std::string>* wanted) {
  if (held.empty()) return {};
  std::vector<std::string> ids;
  std::string epochs = "{";
  for (const auto& [id, epoch] : held) {
    if (!isSessionId(id)) continue;
    if (!ids.empty()) epochs += ',';
    ids.push_back(id);
    epochs += std::to_string(epoch);
  }
  epochs += '}';
  ResultPtr r = pool_->exec(R"sql(
UPDATE myriad_leases l SET expires_at = now() + $3::bigint * interval '1 millisecond'
  FROM unnest($1::text[], $2::bigint[]) AS h(id, epoch)
 WHERE l.session_id = h.id AND l.epoch = h.epoch AND l.owner = $4::integer AND NOT l.deleted
RETURNING l.session_id, l.wanted_by IS NOT NULL)sql",
                            {{textArray(ids)}, {epochs}, {std::to_string(ttl.count())},
                             {std::to_string(node)}});
  std::set<std::string> kept;
  for (int i = 0; i < PQntuples(r.get()); ++i) {
    kept.insert(PQgetvalue(r.get(), i, 0));
    if (wanted != nullptr && PQgetvalue(r.get(), i, 1)[0] == 't') {
      wanted->push_back(PQgetvalue(r.get(), i, 0));
    }
  }
  std::vector<std::string> lost;
  for (const auto& [id, epoch] : held) {
    if (!kept.contains(id)) lost.push_back(id);
  }
  return lost;
}

void PostgresStateStore::release(std::string_view id, uint32_t node, uint64_t epoch) {
  if (!isSessionId(id)) return;
  pool_->exec(
      "UPDATE myriad_leases SET expires_at = now() WHERE session_id = $1 AND owner = $2::integer "
      "AND epoch = $3::bigint AND NOT deleted",
      {{std::string(id)}, {std::to_string(node)}, {std::to_string(epoch)}});
}

bool PostgresStateStore::sweepSome(std::chrono::seconds retention, size_t) {
  const std::string seconds = std::to_string(retention.count());
  ResultPtr sessions = pool_->exec(
      "DELETE FROM myriad_sessions s WHERE s.updated_at < now() - $1::bigint * interval '1 second' "
      "AND NOT EXISTS (SELECT 1 FROM myriad_leases l WHERE l.session_id = s.id "
      "AND l.expires_at > now())",
      {{seconds}});
  // A blob written in the last minute may be named by a record not yet written (an upload's blob
  // goes first).
  ResultPtr blobs = pool_->exec(
      "DELETE FROM myriad_blobs b WHERE b.created_at < now() - interval '1 minute' "
      "AND NOT EXISTS (SELECT 1 FROM myriad_sessions s WHERE b.key = ANY (s.blobs))",
      {});
  std::fprintf(stderr,
               "myriad-server: state: retention sweep of %s removed %s session rows and %s blobs\n",
               description_.c_str(), PQcmdTuples(sessions.get()), PQcmdTuples(blobs.get()));
  return true;
}

}  // namespace myriad::service
