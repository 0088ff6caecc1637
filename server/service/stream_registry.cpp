#include "service/stream_registry.h"

#include <algorithm>
#include <utility>

namespace myriad::service {
namespace {

// Wakes the stream of `session` waiting on its condition variable. Taking the session's mutex
// after the flag was set means its stream is either before its predicate check (and sees the
// flag) or already waiting (and gets the notification).
void wake(Session& session) {
  { std::lock_guard sessionLock(session.mutex); }
  session.changed.notify_all();
}

}  // namespace

StreamRegistry::Slot::Slot(StreamRegistry& registry, SessionPtr session, PeerWatch peer)
    : registry_(registry), session_(std::move(session)), peer_(peer) {}

StreamRegistry::Slot::~Slot() {
  std::lock_guard lock(registry_.mutex_);
  registry_.open_.remove(this);
}

std::unique_ptr<StreamRegistry::Slot> StreamRegistry::open(SessionPtr session,
                                                           uint32_t maxPerSession, PeerWatch peer,
                                                           Refusal* refusal) {
  auto refuse = [&](Refusal why) -> std::unique_ptr<Slot> {
    if (refusal != nullptr) *refusal = why;
    return nullptr;
  };
  std::lock_guard lock(mutex_);
  if (stopping_) return refuse(Refusal::stopping);
  if (liveCount() >= maxStreams_ || liveCount(session) >= maxPerSession) reclaimGone();
  if (liveCount() >= maxStreams_) {
    auto oldest = std::find_if(open_.begin(), open_.end(), [&](const Slot* slot) {
      return !slot->replaced() && slot->session_ == session;
    });
    if (oldest == open_.end()) return refuse(Refusal::maxStreams);
    (*oldest)->replaced_ = true;
    wake(*session);
  } else if (liveCount(session) >= maxPerSession) {
    // Below the server's limit but at the session's share: the place is another session's.
    return refuse(Refusal::maxStreamsPerSession);
  }
  auto slot = std::make_unique<Slot>(*this, std::move(session), peer);
  open_.push_back(slot.get());
  if (refusal != nullptr) *refusal = Refusal::none;
  return slot;
}

void StreamRegistry::reclaimGone() {
  for (Slot* slot : open_) {
    if (slot->replaced() || !slot->peer_.gone()) continue;
    slot->replaced_ = true;
    wake(*slot->session_);
  }
}

uint32_t StreamRegistry::count() const {
  std::lock_guard lock(mutex_);
  return liveCount();
}

uint32_t StreamRegistry::liveCount() const {
  return static_cast<uint32_t>(std::count_if(
      open_.begin(), open_.end(), [](const Slot* slot) { return !slot->replaced(); }));
}

uint32_t StreamRegistry::liveCount(const SessionPtr& session) const {
  return static_cast<uint32_t>(std::count_if(open_.begin(), open_.end(), [&](const Slot* slot) {
    return !slot->replaced() && slot->session_ == session;
  }));
}

void StreamRegistry::shutdown() {
  std::lock_guard lock(mutex_);
  stopping_ = true;
  for (const Slot* slot : open_) wake(*slot->session_);
}

}  // namespace myriad::service
