#include "service/shared_frames.h"

#include <malloc.h>

#include <algorithm>
#include <functional>
#include <future>
#include <utility>

#include "protocol/constants.h"

namespace myriad::service {
namespace {

// How often a video frame waiting for the renderer looks whether its client left.
constexpr std::chrono::milliseconds kGonePoll{10};
// An entry no stream asked for in this long goes (its frame with it).
constexpr std::chrono::seconds kUnusedEntry{10};

// The session's version and whether it animates, under its lock (taken after SharedFrames'
// own: nothing takes them the other way round).
struct SessionNow {
  uint64_t version;
  bool animate;
};
SessionNow sessionNow(Session& session) {
  std::lock_guard sessionLock(session.mutex);
  return {session.version, session.scene.moving()};
}

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
    const SessionNow current = sessionNow(*session);
    const Clock::time_point now = Clock::now();
    dropStale(now);
    Entry& entry = entries_[key];
    entry.session = session;
    entry.usedAt = now;
    const bool fits = entry.encoded && entry.generation != shown &&
                      entry.version == current.version &&
                      (!current.animate || now - entry.renderedAt < maxAge);
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

// ---- Video channels.

std::string SharedFrames::videoKeyOf(const Session& session, const FrameRequest& request,
                                     const encode::VideoSettings& settings) {
  return session.id + '|' + std::to_string(static_cast<int>(request.settings.target)) + '|' +
         std::to_string(settings.width) + 'x' + std::to_string(settings.height) + '|' +
         std::string(encode::videoCodecName(settings.codec)) + '|' +
         std::to_string(settings.bitrateKbps) + "kbps|" + std::to_string(settings.fps) + "fps";
}

SharedFrames::VideoViewer SharedFrames::joinVideo(const SessionPtr& session,
                                                  const FrameRequest& request,
                                                  const encode::VideoSettings& settings) {
  const std::string key = videoKeyOf(*session, request, settings);
  {
    std::lock_guard lock(mutex_);
    std::erase_if(channels_, [](const auto& item) { return item.second.expired(); });
    if (auto it = channels_.find(key); it != channels_.end()) {
      if (std::shared_ptr<VideoChannel> channel = it->second.lock()) return {channel};
    }
  }
  // A new channel, made without the lock; its encoder comes with its first encode. On the pool,
  // the encoder's threads come from the pool's size and the channels already open.
  encode::VideoSettings chosen = settings;
  if (pool_ != nullptr) {
    chosen.threads = encode::encoderThreadsFor(settings.codec, settings.width, settings.height,
                                               pool_->threads(), videoChannelCount());
  }
  auto made = std::make_shared<VideoChannel>(key, chosen, encoderCounts_);
  std::lock_guard lock(mutex_);
  std::weak_ptr<VideoChannel>& slot = channels_[key];
  if (std::shared_ptr<VideoChannel> raced = slot.lock()) return {raced};  // another joined first
  slot = made;
  return {made};
}

std::vector<SharedFrames::VideoFramePtr> SharedFrames::sliceFor(const VideoChannel& channel,
                                                                uint64_t position,
                                                                size_t backlog) {
  if (channel.log.empty()) return {};
  const uint64_t first = channel.log.front()->generation;
  const uint64_t newest = channel.log.back()->generation;
  if (position >= newest) return {};
  if (position > 0 && position + 1 >= first && newest - position <= backlog) {
    // Keeping up: everything after its position.
    return {channel.log.begin() + static_cast<std::ptrdiff_t>(position + 1 - first),
            channel.log.end()};
  }
  // Joined, or too far behind: the log from a key frame, when short.
  if (channel.log.front()->key && channel.log.size() <= kMaxVideoReplay) {
    return {channel.log.begin(), channel.log.end()};
  }
  return {};
}

void SharedFrames::wantKey(VideoChannel& channel, VideoViewer& viewer, Clock::time_point now) {
  channel.keyWanted = true;
  if (viewer.skipping) return;  // counted when it started waiting
  viewer.skipping = true;
  if (viewer.position == 0) return;  // a joiner
  // A viewer that had frames and fell behind: count it, and step the bitrate down.
  ++viewer.resyncs;
  ++videoResyncs_;
  if (now - channel.lastDown >= videoLowerEvery_) {
    const uint32_t floor = std::max(1u, channel.askedKbps / 4);
    channel.targetKbps =
        std::max(floor, static_cast<uint32_t>(uint64_t(channel.targetKbps) * 3 / 4));
    channel.lastDown = now;
    channel.lastStep = now;
  }
}

std::vector<SharedFrames::VideoFramePtr> SharedFrames::nextVideo(
    const SessionFrameContext& context, const SessionPtr& session, const FrameRequest& request,
    VideoViewer& viewer, Clock::duration maxAge, const std::function<bool()>& gone) {
  VideoChannel& channel = *viewer.channel;
  const size_t backlog = maxVideoBacklog(request.fps);
  std::unique_lock lock(mutex_);
  for (;;) {
    const SessionNow current = sessionNow(*session);
    const Clock::time_point now = Clock::now();
    if (!channel.log.empty()) {
      const VideoFrame& newest = *channel.log.back();
      const bool fits = newest.generation > viewer.position &&
                        newest.version == current.version &&
                        (!current.animate || now - newest.renderedAt < maxAge);
      if (fits) {
        std::vector<VideoFramePtr> slice = sliceFor(channel, viewer.position, backlog);
        if (!slice.empty()) {
          shared_ += slice.size();
          viewer.position = slice.back()->generation;
          viewer.skipping = false;
          return slice;
        }
        // Too far behind (or joined late): skip to the next key frame, which the next encode
        // makes (whoever makes it).
        wantKey(channel, viewer, now);
      }
    }
    if (channel.rendering) {
      // Another viewer renders and encodes this channel's next frame: take it rather than make
      // a second.
      rendered_.wait(lock, [&] { return !channel.rendering; });
      continue;
    }
    channel.rendering = true;
    const bool forceKey = channel.keyWanted || channel.log.empty();
    if (channel.targetKbps < channel.askedKbps && now - channel.lastStep >= videoRaiseAfter_) {
      // No viewer fell behind for a while: one step back up.
      channel.targetKbps = static_cast<uint32_t>(
          std::min<uint64_t>(channel.askedKbps, uint64_t(channel.targetKbps) * 5 / 4 + 1));
      channel.lastStep = now;
    }
    const uint32_t kbps = channel.targetKbps;
    lock.unlock();
    auto made = std::make_shared<VideoFrame>();
    SessionFrame frame;
    try {
      const FrameEncoder encode = [&](const render::Frame& f) {
        // Rendered for a client that left meanwhile, and nobody else: no encode (and, for a
        // stream's first frame, no encoder).
        if (gone && viewer.channel.use_count() == 1 && gone()) throw ViewerGone();
        const auto start = Clock::now();
        made->timestampUs = static_cast<uint64_t>(
            std::chrono::duration_cast<std::chrono::microseconds>(start - channel.startedAt)
                .count());
        encode::VideoPacket packet;
        Clock::time_point began = start;  // the encode's own start, after its turn came
        const std::function<void()> job = [&] {
          began = Clock::now();
          packet = channel.encode(f.pixels(), made->timestampUs / 1000, forceKey);
        };
        if (pool_ != nullptr) {
          // In the session's turn on the shared pool, holding as many of its cores as the
          // encoder has threads; this worker waits (the frame's pixels stay where they are).
          pool_->run(session->id, channel.encoder.settings().threads, job);
        } else {
          job();
        }
        EncodedFrame out;
        out.body.assign(reinterpret_cast<const char*>(packet.data.data()), packet.data.size());
        out.contentType = protocol::kVideoStreamContentType;
        // The encode itself: the wait for its turn is myriad_encode_wait_seconds_total's.
        out.encodeMs = std::chrono::duration<double, std::milli>(Clock::now() - began).count();
        made->key = packet.key;
        made->width = f.width;
        made->height = f.height;
        made->encodeUs = static_cast<uint32_t>(out.encodeMs * 1000.0);
        return out;
      };
      if (channel.encoder.settings().bitrateKbps != kbps) channel.encoder.setBitrate(kbps);
      PendingSessionFrame pending =
          submitSessionFrame(context, session, request, render::FrameSource::Stream);
      if (gone) {
        // A client that leaves while its frame waits for the renderer gives the frame up (not
        // rendered unless it started): a client opening and dropping streams costs no renders
        // that other sessions' frames would wait behind.
        while (pending.frame.wait_for(kGonePoll) != std::future_status::ready) {
          if (viewer.channel.use_count() == 1 && gone()) {
            *pending.drop = true;
            break;
          }
        }
      }
      try {
        frame = collectSessionFrame(context, session, pending, &encode);
      } catch (const render::FrameDroppedError&) {
        throw ViewerGone();
      }
    } catch (...) {
      lock.lock();
      channel.rendering = false;
      rendered_.notify_all();
      throw;
    }
    made->payload = std::move(frame.encoded.body);
    made->version = frame.version;
    made->time = frame.time;
    lock.lock();
    ++videoEncodes_;
    made->generation = ++channel.generations;
    made->renderedAt = Clock::now();
    if (made->key) {
      // Nothing before a key frame is needed to decode what follows.
      channel.log.clear();
      channel.logBytes = 0;
      channel.keyWanted = false;
    }
    channel.logBytes += made->payload.size();
    channel.log.push_back(std::move(made));
    while (channel.log.size() > 1 &&
           (channel.log.size() > backlog + 1 || channel.logBytes > kMaxVideoLogBytes)) {
      channel.logBytes -= channel.log.front()->payload.size();
      channel.log.pop_front();
    }
    channel.rendering = false;
    rendered_.notify_all();
    std::vector<VideoFramePtr> slice = sliceFor(channel, viewer.position, backlog);
    if (!slice.empty()) {
      shared_ += slice.size() - 1;  // all but the one made here
      viewer.position = slice.back()->generation;
      viewer.skipping = false;
      return slice;
    }
    // Still too far behind (its own frame was not a key frame: the request came during it).
    wantKey(channel, viewer, Clock::now());
  }
}

void SharedFrames::capVideoBitrate(VideoViewer& viewer, uint32_t kbps) {
  VideoChannel& channel = *viewer.channel;
  std::lock_guard lock(mutex_);
  const uint32_t floor = std::max(1u, channel.askedKbps / 4);
  const auto capped = static_cast<uint32_t>(uint64_t(kbps) * 85 / 100);
  if (capped >= channel.targetKbps) return;
  channel.targetKbps = std::max(floor, capped);
  const Clock::time_point now = Clock::now();
  channel.lastDown = now;
  channel.lastStep = now;
}

SharedFrames::VideoChannel::FreedNotice::~FreedNotice() {
  if (!made) return;
  counts->freed.fetch_add(1);
  // glibc keeps what a freed encoder gave back (libvpx's frame buffers and tables, megabytes)
  // in its arenas rather than return it: 100 VP9 streams opened and dropped left 290 MiB more
  // resident for good (hostile_players CTest). Trimming here returns it; it takes well under a
  // millisecond, once per encoder.
  malloc_trim(0);
}

uint64_t SharedFrames::videoEncodeCount() const {
  std::lock_guard lock(mutex_);
  return videoEncodes_;
}

uint64_t SharedFrames::videoResyncCount() const {
  std::lock_guard lock(mutex_);
  return videoResyncs_;
}

uint32_t SharedFrames::videoChannelCount() const {
  std::lock_guard lock(mutex_);
  return static_cast<uint32_t>(std::count_if(channels_.begin(), channels_.end(), [](const auto& item) {
    return !item.second.expired();
  }));
}

}  // namespace myriad::service
