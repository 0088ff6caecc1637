// SessionManager without HTTP or a GPU: ids and tokens, the order of 401/403/404, the session
// limit, release on delete, expiry by the sweeper, and waiting for a change.
#include <doctest/doctest.h>

#include <stdlib.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <regex>
#include <set>
#include <thread>

#include "service/session.h"
#include "service/state_store.h"

using namespace myriad::service;
using namespace std::chrono_literals;

namespace {

int statusOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const ProblemError& e) {
    return e.problem().status;
  }
  return 200;
}

Credentials bearer(const std::string& token) { return Credentials{"Bearer " + token, {}}; }

// What the API does right after create(): a session without a scene is "being created" and
// neither expires nor is released.
void markReady(Session& session, uint64_t sceneId) {
  std::lock_guard lock(session.mutex);
  session.sceneId = sceneId;
}

}  // namespace

TEST_CASE("sessions: tokens compare in constant time and parse from Bearer only") {
  CHECK(constantTimeEquals("abc", "abc"));
  CHECK_FALSE(constantTimeEquals("abc", "abd"));
  CHECK_FALSE(constantTimeEquals("abc", "abcd"));
  CHECK(constantTimeEquals("", ""));
  CHECK(bearerToken("Bearer xyz") == std::optional<std::string>("xyz"));
  CHECK_FALSE(bearerToken("bearer xyz").has_value());
  CHECK_FALSE(bearerToken("Basic xyz").has_value());
  CHECK_FALSE(bearerToken("Bearer ").has_value());
  CHECK_FALSE(bearerToken("Bearer a b").has_value());
  CHECK_FALSE(bearerToken("Bearer " + std::string(300, 'a')).has_value());
}

TEST_CASE("sessions: ids, tokens, the limit and who may see what") {
  std::vector<std::string> released;
  std::mutex releasedMutex;
  SessionManager manager(2, 600s, [&](Session& s) {
    std::lock_guard lock(releasedMutex);
    released.push_back(s.id);
  });
  SessionPtr a = manager.create();
  SessionPtr b = manager.create();
  markReady(*a, 1);
  markReady(*b, 2);
  CHECK(std::regex_match(a->id, std::regex("s-[0-9a-f]{16}")));
  CHECK(std::regex_match(a->token, std::regex("[0-9a-f]{64}")));
  CHECK(a->id != b->id);
  CHECK(a->token != b->token);
  CHECK(manager.count() == 2);

  // The limit: 429 naming maxSessions.
  try {
    manager.create();
    FAIL("a third session was created");
  } catch (const ProblemError& e) {
    CHECK(e.problem().status == 429);
    CHECK(e.problem().limit == std::optional<std::string>("maxSessions"));
    CHECK(e.problem().retryAfterSeconds.has_value());
  }

  CHECK(manager.authorize(a->id, bearer(a->token)) == a);
  CHECK(statusOf([&] { manager.authorize(a->id, {}); }) == 401);
  CHECK(statusOf([&] { manager.authorize(a->id, Credentials{"Token x", {}}); }) == 401);
  CHECK(statusOf([&] { manager.authorize(a->id, bearer(std::string(64, 'f'))); }) == 401);
  CHECK(statusOf([&] { manager.authorize(a->id, bearer(b->token)); }) == 403);
  CHECK(statusOf([&] { manager.authorize("s-0000000000000000", bearer(a->token)); }) == 404);
  // ?token= only where the route allows it; the header wins when both are present.
  CHECK(statusOf([&] { manager.authorize(a->id, Credentials{{}, a->token}); }) == 401);
  CHECK(manager.authorize(a->id, Credentials{{}, a->token}, true) == a);
  CHECK(statusOf([&] {
          manager.authorize(a->id, Credentials{"Bearer " + b->token, a->token}, true);
        }) == 403);

  // Delete: closed, released, gone; its token is nobody's.
  CHECK(manager.remove(a->id));
  CHECK_FALSE(manager.remove(a->id));
  CHECK(a->closed);
  CHECK(released == std::vector<std::string>{a->id});
  CHECK(statusOf([&] { manager.authorize(a->id, bearer(a->token)); }) == 404);
  CHECK(statusOf([&] { manager.authorize(b->id, bearer(a->token)); }) == 401);
  CHECK(manager.count() == 1);
  SessionPtr c = manager.create();  // the place is free again
  CHECK(manager.find(c->id) == c);
  CHECK(manager.find(a->id) == nullptr);
}

TEST_CASE("sessions: idle sessions expire; authorized requests refresh them") {
  std::atomic<int> releases{0};
  SessionManager manager(4, 1s, [&](Session&) { ++releases; });
  SessionPtr idle = manager.create();
  SessionPtr busy = manager.create();
  SessionPtr creating = manager.create();  // no scene yet: never expires under its creator
  markReady(*idle, 1);
  markReady(*busy, 2);
  CHECK(manager.expiresInSeconds(*idle) == 1);
  const auto start = Clock::now();
  while (Clock::now() - start < 2500ms) {
    manager.authorize(busy->id, bearer(busy->token));
    std::this_thread::sleep_for(100ms);
  }
  CHECK(manager.find(idle->id) == nullptr);
  CHECK(idle->closed);
  CHECK(manager.find(busy->id) == busy);
  CHECK(manager.find(creating->id) == creating);
  CHECK(releases == 1);
  CHECK(manager.expiresInSeconds(*busy) >= 0);
}

TEST_CASE("sessions: a waiter wakes on a change and on close") {
  SessionManager manager(4, 600s, nullptr);
  SessionPtr s = manager.create();
  markReady(*s, 1);
  uint64_t seen = 0;
  {
    std::lock_guard lock(s->mutex);
    seen = s->version;
  }
  // No change: the wait times out with the same version.
  CHECK(s->waitForChange(seen, Clock::now() + 50ms) == seen);
  std::thread editor([&] {
    std::this_thread::sleep_for(50ms);
    std::lock_guard lock(s->mutex);
    s->bump();
  });
  const auto start = Clock::now();
  CHECK(s->waitForChange(seen, Clock::now() + 10s) == seen + 1);
  CHECK(Clock::now() - start < 5s);
  editor.join();

  std::thread closer([&] {
    std::this_thread::sleep_for(50ms);
    manager.remove(s->id);
  });
  CHECK(s->waitForChange(seen + 1, Clock::now() + 10s) == seen + 1);
  CHECK(s->closed);
  closer.join();
}

TEST_CASE("sessions: --node-id puts the node's number at the start of every id") {
  SessionManager sessions(8, std::chrono::seconds(60), nullptr);
  sessions.setNode(0xa7);
  for (int i = 0; i < 4; ++i) {
    SessionPtr s = sessions.create();
    CHECK(std::regex_match(s->id, std::regex("s-a7[0-9a-f]{14}")));
  }
}
