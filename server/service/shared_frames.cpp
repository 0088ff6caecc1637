#include "service/shared_frames.h"

#include <utility>

namespace myriad::service {
namespace {

// An entry no stream asked for in this long goes (its frame with it).
constexpr std::chrono::seconds kUnusedEntry{10};

}  // namespace

std::string SharedFrames::keyOf(const Session& session, const FrameRequest& request) {
  const render::FrameSettings& s = request.settings;
  return session.id + '|' + std::to_string(static_cast<int>(s.target)) + '|' +
         std::to_string(s.width) + 'x' + std::to_string(s.height) + '|' +
         std::to_string(static_cast<int>(request.format)) + '|' + std::to_string(request.quality);
}

void SharedFrames::dropStale(Clock::time_point now) {
  for (auto it = entries_.begin(); it != entries_.end();) {
    const Entry& e = it->second;
    const bool stale = !e.rendering && (e.session.expired() || now - e.usedAt > kUnusedEntry);
    it = stale ? entries_.erase(it) : std::next(it);
  }
}

SharedFrames::Frame SharedFrames::next(const SessionFrameContext& context,
                                       const SessionPtr& session, const FrameRequest& request,
                                       uint64_t shown, Clock::duration maxAge) {
  const std::string key = keyOf(*session, request);
  std::unique_lock lock(mutex_);
  for (;;) {
    // The session's version and animation now (its lock after ours: nothing takes them the
    // other way round).
    uint64_t version = 0;
    bool animate = false;
    {
      std::lock_guard sessionLock(session->mutex);
      version = session->version;
      animate = session->scene.settings().animate;
    }
    const Clock::time_point now = Clock::now();
    dropStale(now);
    Entry& entry = entries_[key];
    entry.session = session;
    entry.usedAt = now;
    const bool fits = entry.encoded && entry.generation != shown && entry.version == version &&
                      (!animate || now - entry.renderedAt < maxAge);
    if (fits) {
      ++shared_;
      return {entry.encoded, entry.version, entry.generation, entry.took};
    }
    if (entry.rendering) {
      // Another stream renders this picture now: take its frame rather than queue a second.
      rendered_.wait(lock, [&] {
        auto it = entries_.find(key);
        return it == entries_.end() || !it->second.rendering;
      });
      continue;
    }
    entry.rendering = true;
    lock.unlock();
    SessionFrame frame;
    try {
      frame = renderSessionFrame(context, session, request, render::FrameSource::Stream);
    } catch (...) {
      lock.lock();
      entries_[key].rendering = false;
      rendered_.notify_all();
      throw;
    }
    lock.lock();
    Entry& done = entries_[key];  // still there: an entry is never dropped while rendering
    done.rendering = false;
    done.encoded = std::make_shared<const EncodedFrame>(std::move(frame.encoded));
    done.version = frame.version;
    // Fresh from now on: a stream that waited for it takes it whatever the render took.
    done.renderedAt = Clock::now();
    done.took = done.renderedAt - now;
    done.generation = ++generations_;
    rendered_.notify_all();
    return {done.encoded, done.version, done.generation, done.took};
  }
}

uint64_t SharedFrames::sharedCount() const {
  std::lock_guard lock(mutex_);
  return shared_;
}

}  // namespace myriad::service
