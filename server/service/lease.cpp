#include "service/lease.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <vector>

#include "service/problem.h"

namespace myriad::service {

namespace {

thread_local std::optional<uint32_t> tOwnerHint;

Problem storeUnavailable(const StateStore& store, const std::string& why) {
  Problem problem = serverBusy("The session store (" + store.describe() +
                               ") cannot be reached: " + why + ". Retry shortly.");
  problem.retryAfterSeconds = 1;
  return problem;
}

}  // namespace

std::optional<uint32_t> takeOwnerHint() {
  std::optional<uint32_t> hint = tOwnerHint;
  tOwnerHint.reset();
  return hint;
}

LeaseKeeper::LeaseKeeper(StateStore& store, uint32_t node, std::chrono::milliseconds ttl,
                         Lost onLost)
    : store_(store), node_(node), ttl_(ttl), onLost_(std::move(onLost)) {
  thread_ = std::thread([this] { loop(); });
}

LeaseKeeper::~LeaseKeeper() {
  std::map<std::string, Held, std::less<>> held;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    held.swap(held_);
  }
  wake_.notify_all();
  thread_.join();
  for (const auto& [id, h] : held) {
    try {
      store_.release(id, node_, h.epoch);
    } catch (const std::exception&) {
      // The store went away: the lease lapses by itself.
    }
  }
}

std::chrono::steady_clock::time_point LeaseKeeper::validFrom(
    std::chrono::steady_clock::time_point sent) const {
  return sent + ttl_ * 4 / 5;
}

uint64_t LeaseKeeper::acquire(std::string_view id, bool fresh) {
  // The session's home: the node its id names ("s-" + 2 hex digits of --node-id).
  bool home = false;
  if (node_ <= 255 && id.size() >= 4) {
    static constexpr char kHex[] = "0123456789abcdef";
    home = id[2] == kHex[(node_ >> 4) & 15] && id[3] == kHex[node_ & 15];
  }
  // The home node asks the owner to hand the session over (at its next renewal, a quarter of the
  // lease time away) or waits for a dead owner's lease to lapse: at most the lease time.
  const auto handoverDeadline =
      std::chrono::steady_clock::now() + ttl_ + std::chrono::milliseconds(100);
  // Another node's lease as first seen here: when it runs out (a live owner's moves later).
  std::optional<std::chrono::steady_clock::time_point> othersExpiry;
  for (;;) {
    const auto sent = std::chrono::steady_clock::now();
    LeaseGrant grant;
    try {
      grant = store_.acquire(id, node_, ttl_, fresh, home && !fresh);
    } catch (const StoreUnavailable& e) {
      throw ProblemError(storeUnavailable(store_, e.what()));
    }
    if (grant.held) {
      ++acquired_;
      uint64_t seen = maxEpoch_.load();
      while (grant.lease.epoch > seen && !maxEpoch_.compare_exchange_weak(seen, grant.lease.epoch)) {
      }
      std::lock_guard lock(mutex_);
      held_[std::string(id)] = {grant.lease.epoch, validFrom(sent)};
      return grant.lease.epoch;
    }
    if (grant.lease.deleted || grant.lease.epoch == 0) {
      // No lease to take: a deleted session (its record is gone too).
      throw ProblemError(notFoundDetail("The session " + quoteClientText(id) +
                                        " was deleted."));
    }
    if (home && !fresh && std::chrono::steady_clock::now() < handoverDeadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
      continue;
    }
    // Another node's lease: a crashed owner's runs out within the lease time; wait for that,
    // looking again every quarter of the lease time. A lease that moved later was renewed: its
    // owner is alive (a hung node continued, say), and the request is answered 409 naming it at
    // once rather than after a whole lease time (as is every request queued behind this one).
    const auto now = std::chrono::steady_clock::now();
    const auto left = std::chrono::milliseconds(std::max<int64_t>(grant.lease.expiresInMs, 0));
    if (!othersExpiry) othersExpiry = now + left;
    const bool renewed = now + left > *othersExpiry + std::chrono::milliseconds(50);
    if (!fresh && !renewed && left <= ttl_ &&
        now < *othersExpiry + std::chrono::milliseconds(200)) {
      std::this_thread::sleep_for(std::min(left + std::chrono::milliseconds(20),
                                           std::max(ttl_ / 4, std::chrono::milliseconds(20))));
      continue;
    }
    ++refused_;
    tOwnerHint = grant.lease.owner;
    Problem problem = conflict(
        "The session " + quoteClientText(id) + " is served by node " +
        std::to_string(grant.lease.owner) + " (its lease, epoch " +
        std::to_string(grant.lease.epoch) + ", runs another " +
        std::to_string(std::max<int64_t>(grant.lease.expiresInMs, 0)) +
        " ms); send its requests there (X-Myriad-Owner).");
    throw ProblemError(problem);
  }
}

bool LeaseKeeper::holds(std::string_view id, uint64_t epoch) {
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mutex_);
    auto it = held_.find(id);
    if (it == held_.end() || it->second.epoch != epoch) return false;
    if (now < it->second.validUntil) return true;
  }
  // Not renewed lately (the store was slow or away, or this process was stopped): ask now.
  std::vector<std::string> lost;
  try {
    lost = store_.renew(node_, {{std::string(id), epoch}}, ttl_);
  } catch (const StoreUnavailable&) {
    ++renewFailures_;
    return false;
  }
  std::lock_guard lock(mutex_);
  auto it = held_.find(id);
  if (it == held_.end() || it->second.epoch != epoch) return false;
  if (!lost.empty()) {
    held_.erase(it);
    ++lost_;
    return false;
  }
  it->second.validUntil = validFrom(now);
  return true;
}

void LeaseKeeper::release(std::string_view id, uint64_t epoch) {
  {
    std::lock_guard lock(mutex_);
    auto it = held_.find(id);
    if (it == held_.end() || it->second.epoch != epoch) return;
    held_.erase(it);
  }
  try {
    store_.release(id, node_, epoch);
  } catch (const std::exception&) {
    // The lease lapses by itself.
  }
}

void LeaseKeeper::dropped(std::string_view id, uint64_t epoch) {
  std::lock_guard lock(mutex_);
  auto it = held_.find(id);
  if (it != held_.end() && it->second.epoch == epoch) {
    held_.erase(it);
    ++lost_;
  }
}

void LeaseKeeper::loop() {
  const auto period = std::max(ttl_ / 4, std::chrono::milliseconds(10));
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_; });
    if (stopping_) break;
    std::vector<std::pair<std::string, uint64_t>> held;
    for (const auto& [id, h] : held_) held.emplace_back(id, h.epoch);
    lock.unlock();
    const auto sent = std::chrono::steady_clock::now();
    std::vector<std::string> lost;
    std::vector<std::string> wanted;
    bool renewed = false;
    if (!held.empty()) {
      try {
        lost = store_.renew(node_, held, ttl_, &wanted);
        renewed = true;
      } catch (const std::exception& e) {
        ++renewFailures_;
        std::fprintf(stderr, "myriad-server: leases not renewed: %s\n", e.what());
      }
    }
    std::vector<std::pair<std::string, uint64_t>> gone;
    std::vector<std::pair<std::string, uint64_t>> handedOver;
    lock.lock();
    if (renewed) {
      for (const auto& [id, epoch] : held) {
        auto it = held_.find(id);
        if (it == held_.end() || it->second.epoch != epoch) continue;
        if (std::find(lost.begin(), lost.end(), id) != lost.end()) {
          held_.erase(it);
          ++lost_;
          gone.emplace_back(id, epoch);
        } else if (std::find(wanted.begin(), wanted.end(), id) != wanted.end()) {
          // The session's home node asks for it: the copy here closes first, then the lease
          // goes, so nothing is served here once the home node may serve it.
          held_.erase(it);
          ++handovers_;
          handedOver.emplace_back(id, epoch);
        } else {
          it->second.validUntil = validFrom(sent);
        }
      }
    }
    if (!gone.empty() || !handedOver.empty()) {
      lock.unlock();
      for (const auto& [id, epoch] : gone) {
        std::fprintf(stderr, "myriad-server: session %s: lease (epoch %llu) lost; closed here\n",
                     id.c_str(), static_cast<unsigned long long>(epoch));
        if (onLost_) onLost_(id, epoch);
      }
      for (const auto& [id, epoch] : handedOver) {
        std::fprintf(stderr, "myriad-server: session %s: handed over to its home node\n",
                     id.c_str());
        if (onLost_) onLost_(id, epoch);
        try {
          store_.release(id, node_, epoch);
        } catch (const std::exception&) {
          // The lease lapses by itself.
        }
      }
      lock.lock();
    }
  }
}

std::string LeaseKeeper::exposition(std::string_view labels) const {
  size_t held = 0;
  {
    std::lock_guard lock(mutex_);
    held = held_.size();
  }
  // Appended piece by piece (GCC 12 warns falsely, -Wrestrict, on "{" + std::string).
  std::string l;
  if (!labels.empty()) l.append(1, '{').append(labels).append(1, '}');
  std::string out;
  auto series = [&](const char* name, const char* type, const char* help, uint64_t value) {
    out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n" +
           name + l + " " + std::to_string(value) + "\n";
  };
  series("myriad_leases_held", "gauge", "Session leases this node holds now.", held);
  series("myriad_lease_epoch_max", "gauge", "The highest lease epoch this node has taken.",
         maxEpoch_.load());
  series("myriad_lease_acquired_total", "counter", "Session leases taken (create, restore).",
         acquired_.load());
  series("myriad_lease_takeovers_total", "counter",
         "Sessions restored here whose lease another node held before (failover).",
         takeovers.load());
  series("myriad_lease_refused_total", "counter",
         "Requests answered 409: the session's lease is another node's, live.", refused_.load());
  series("myriad_lease_handovers_total", "counter",
         "Sessions this node handed to their home node on its asking (copy closed, lease given).",
         handovers_.load());
  series("myriad_lease_lost_total", "counter",
         "Leases this node lost (taken over, deleted elsewhere); their copies closed.",
         lost_.load());
  series("myriad_lease_renew_failures_total", "counter",
         "Lease renewals that did not reach the store.", renewFailures_.load());
  series("myriad_state_writes_fenced_total", "counter",
         "Session writes the store refused: a stale epoch or version.", fencedWrites.load());
  series("myriad_state_write_failures_total", "counter",
         "Session writes that did not reach the store.", failedWrites.load());
  return out;
}

}  // namespace myriad::service
