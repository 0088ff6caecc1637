// The PostgreSQL state store (service/store_postgres.h) against a cluster the test starts
// (scripts/with_postgres.py sets MYRIAD_TEST_POSTGRES): the store contract (store_contract.h)
// with two stores on one database, as two servers would have; rows that are not records refused
// (a line on stderr, treated as absent), never a crash; connections the database dropped
// replaced on the next call; a database that cannot be reached a clear error.
#include <doctest/doctest.h>
#include <libpq-fe.h>

#include <cstdlib>
#include <string>

#include "service/store_postgres.h"
#include "store_contract.h"

using namespace myriad::service;

namespace {

std::string url() {
  const char* u = std::getenv("MYRIAD_TEST_POSTGRES");
  REQUIRE_MESSAGE(u != nullptr, "run under scripts/with_postgres.py (MYRIAD_TEST_POSTGRES)");
  return u;
}

// One statement over a connection of the test's own.
void sql(const std::string& statement) {
  PGconn* c = PQconnectdb(url().c_str());
  REQUIRE(PQstatus(c) == CONNECTION_OK);
  PGresult* r = PQexec(c, statement.c_str());
  const ExecStatusType status = PQresultStatus(r);
  CHECK_MESSAGE((status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK),
                PQresultErrorMessage(r));
  PQclear(r);
  PQfinish(c);
}

}  // namespace

TEST_CASE("store postgres: versions, leases, fencing and deletion as the contract says") {
  sql("DROP TABLE IF EXISTS myriad_sessions, myriad_leases, myriad_blobs");
  PostgresStateStore a(url());
  PostgresStateStore b(url());
  contract::checkStore(a, b);
}

TEST_CASE("store postgres: corrupt and oversized rows are refused, the others load") {
  StateLimits small;
  small.recordBytes = 4096;
  PostgresStateStore store(url(), small);
  const std::string good = "s-0a00000000000001";
  REQUIRE(store.acquire(good, 1, std::chrono::seconds(10), true).held);
  REQUIRE(store.save(contract::record(good, 1, 1, 30), 1).outcome == WriteOutcome::written);
  const char* bad[][2] = {
      {"s-0a00000000000002", "not json at all"},
      {"s-0a00000000000003", "{\"format\":1,\"id\":\"s-0a00000000000003\"}"},
      {"s-0a00000000000004", "{\"format\":1,\"id\":\"s-0affffffffffffff\",\"version\":1,"
                             "\"tokenSha256\":\"0000000000000000000000000000000000000000000000000000000000000000\","
                             "\"snapshot\":{}}"},
  };
  for (const auto& [id, text] : bad) {
    sql(std::string("INSERT INTO myriad_sessions (id, version, record) VALUES ('") + id +
        "', 1, '" + text + "')");
    CHECK_FALSE(store.load(id));
    CHECK_FALSE(store.load(id));  // refused once, remembered: no second line
  }
  sql("INSERT INTO myriad_sessions (id, version, record) VALUES ('s-0a00000000000005', 1, "
      "repeat('x', 10000))");
  CHECK_FALSE(store.load("s-0a00000000000005"));
  CHECK_FALSE(store.load("../../etc/passwd"));
  std::optional<StoredSession> loaded = store.load(good);
  REQUIRE(loaded);
  CHECK(loaded->snapshot["fov"] == 30);
  // A blob whose bytes are not its key's.
  sql("INSERT INTO myriad_blobs (key, bytes) VALUES ('" + sha256Hex("a") + "', 'b'::bytea)");
  std::string why;
  CHECK_FALSE(store.blob(sha256Hex("a"), &why));
  CHECK(why == "its bytes are not the ones its key hashes");
}

TEST_CASE("store postgres: dropped connections are replaced; an unreachable database is one sentence") {
  PostgresStateStore store(url());
  const std::string id = "s-0b00000000000001";
  REQUIRE(store.acquire(id, 1, std::chrono::seconds(10), true).held);
  REQUIRE(store.save(contract::record(id, 1, 1, 30), 1).outcome == WriteOutcome::written);
  // The database ends every connection of the store (a restart, a failover, an administrator).
  sql("SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
      "WHERE application_name = 'myriad-server'");
  std::optional<StoredSession> loaded = store.load(id);
  REQUIRE(loaded);
  CHECK(loaded->version == 1);
  CHECK(store.save(contract::record(id, 2, 1, 31), 1).outcome == WriteOutcome::written);

  try {
    PostgresStateStore nowhere("postgresql://myriad@/myriad?host=/nonexistent&port=1");
    FAIL("a store without a database");
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    CHECK(what.starts_with("The state store: PostgreSQL cannot be reached"));
    CHECK(what.find('\n') == std::string::npos);
  }
}
