#include "service/stream.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <deque>
#include <limits>
#include <optional>
#include <thread>
#include <utility>

#include "encode/encode_pool.h"
#include "service/interactive_quality.h"
#include "service/shared_frames.h"

namespace myriad::service {
namespace {

// How long a stream waits before retrying when the render queue refuses its frame. A stream's
// frames are not counted against --max-queued-frames (render::FrameSource::Stream), so this is
// only the render thread stopping, which the next turn of the loop sees.
constexpr std::chrono::milliseconds kQueueFullRetry{50};

// At most this many writes are remembered for delivery (a client that acknowledges nothing
// for longer is stalled long before).
constexpr size_t kMaxUnackedWrites = 256;
// How often a stream whose client is behind looks again.
constexpr std::chrono::milliseconds kStreamLagPoll{20};
// How long a client must be behind before its link's rate is measured (and used).
constexpr std::chrono::milliseconds kStreamRateWindow{500};

// antialias=taa on a stream: each frame is one jittered frame resolved against the stream's
// history on the GPU (render/temporal.h), keyed by a key of the stream's own. A session that
// stays as it is still gets this many frames of it (at the fps limit), so that a still picture
// converges (8 jitter offsets, then the history's exponential average settles).
constexpr uint32_t kTemporalRefineFrames = 16;
std::atomic<uint64_t> nextHistoryKey{1};

// Everything one stream carries from part to part. Used only by the worker serving the stream.
struct StreamState {
  SessionFrameContext context;
  StreamRegistry& registry;
  std::unique_ptr<StreamRegistry::Slot> slot;
  SessionPtr session;
  FrameRequest request;
  Clock::duration interval;  // 1 / fps
  PeerWatch peer;            // the client's connection
  StreamCredential credential;  // the token it was opened with

  bool hasFrame = false;
  uint64_t shownVersion = 0;  // the session version of the last frame
  uint64_t shownGeneration = 0;  // its SharedFrames generation (0: none, or not shared)
  uint64_t sequence = 0;      // X-Myriad-Frame of the last frame (re-sends keep it)
  std::string image;          // the last frame, for idle re-sends
  std::string contentType;
  bool wroteAny = false;
  Clock::time_point nextFrameAt{};   // the fps limit: no new frame before this
  Clock::time_point lastWriteAt{};
  Clock::time_point lastPartAt{};  // the last new picture's write (stats' intervalMs)
  // Frames in flight: while the lights animate and frames take longer than 1 / fps (the pipeline,
  // not the fps limit, sets the rate), the next frame is submitted the moment this one is
  // rendered, before it is encoded and written, so the render thread renders frame N+1 while this
  // worker encodes and writes frame N. Never earlier: a frame submitted while N still rendered
  // would start at once in the renderer's second slot, and a client closing on frame N would
  // leave two frames rendering for nobody. It shows the session as it was when submitted: an edit
  // made meanwhile shows one frame later.
  std::optional<PendingSessionFrame> ahead;
  Clock::duration lastFrameTook{};  // submit to encoded, of the last frame

  // ?interactive=FPS: frames rendered while the session changes are cheaper, and a full-quality
  // still follows once it settles (interactive_quality.h). Empty when the stream did not ask.
  std::optional<InteractiveQuality> quality;
  uint64_t seenVersion = 0;      // the session version last seen, to time its changes
  bool lastInteractive = false;  // the last frame sent was an interactive one
  // When the last animated interactive frame was collected: the next one's cost as the viewer
  // sees it adds the time from there to its submission (the write, the loop), since animated
  // frames follow each other with nothing to wait for. Unset after any other frame.
  std::optional<Clock::time_point> animatedCollectedAt;
  std::string interactiveScale;  // its render scale, as its part's X-Myriad-Interactive says

  // Video streams (request.video): the stream's place in its SharedFrames channel, whose encoder
  // it shares with every stream of the session asking for the same video.
  std::optional<SharedFrames::VideoViewer> video;
  std::unique_ptr<SharedFrames> ownShared;  // the channels when context.shared is null
  VideoChunk chunk;  // the header of the last chunk written
  // ?container=webm|mp4: the stream's own writer of a standard container (its header, then its
  // frames from its first key frame, timed from 0), instead of chunks. Null: Myriad's chunks.
  std::unique_ptr<encode::ContainerWriter> container;

  // antialias=taa (its history key is request.settings.historyKey): how many frames of the
  // version shown this image stream has sent in a row (kTemporalRefineFrames).
  uint32_t refineFrames = 0;

  // Delivery (stream.h): what the client has taken of what was written, from the kernel's count
  // of unacknowledged bytes (PeerWatch::unacknowledged).
  struct Written {
    uint64_t end;  // `written` after this write
    Clock::time_point at;
  };
  std::deque<Written> unacked;  // writes not wholly acknowledged, oldest first (bounded)
  uint64_t written = 0;         // bytes written to the connection, HTTP chunk framing included
  uint64_t acked = 0;           // of which the client acknowledged
  Clock::time_point progressAt = Clock::now();  // when `acked` last grew (or the stream opened)
  // While the client is behind: the acknowledged bytes and time when it fell behind, for its
  // link's rate (a video channel's bitrate is capped to it).
  std::optional<std::pair<Clock::time_point, uint64_t>> behindSince;

  SharedFrames& shared() { return context.shared ? *context.shared : *ownShared; }

  bool write(httplib::DataSink& sink, const std::string& bytes) {
    wroteAny = true;
    lastWriteAt = Clock::now();
    {
      // Someone watching a stream is using the session, even without other requests: it must
      // not expire under them.
      std::lock_guard lock(session->mutex);
      session->lastUsed = lastWriteAt;
    }
    const bool ok = sink.write(bytes.data(), bytes.size());
    // httplib frames each write as one HTTP chunk: hex size, CRLF, the bytes, CRLF.
    size_t hexDigits = 1;
    for (size_t n = bytes.size(); n >= 16; n /= 16) ++hexDigits;
    written += bytes.size() + hexDigits + 4;
    if (unacked.size() >= kMaxUnackedWrites) unacked.pop_front();
    unacked.push_back({written, Clock::now()});
    return ok;
  }

  // How long the oldest write the client has not wholly acknowledged has waited (zero when all
  // was taken, or the connection is unknown), and whether it made no progress for
  // kStreamWriteStall with bytes outstanding (a reader that stopped, or takes a byte now and
  // then: neither opens the TCP window). Updates `acked` and `progressAt`.
  struct Lag {
    Clock::duration behind{};
    bool stalled = false;
  };
  Lag clientLag(Clock::time_point now) {
    const int64_t outstanding = peer.unacknowledged();
    if (outstanding < 0) return {};
    const uint64_t took = written - std::min<uint64_t>(written, uint64_t(outstanding));
    if (took > acked || outstanding == 0) {
      acked = std::max(acked, took);
      progressAt = now;
    }
    while (!unacked.empty() && unacked.front().end <= acked) unacked.pop_front();
    if (unacked.empty() || outstanding == 0) return {};
    return {now - unacked.front().at, now - progressAt >= kStreamWriteStall};
  }

  // The lag a client may run behind before its stream stops making frames for it: kStreamLag
  // plus twice the connection's round trip (a frame is acknowledged a round trip after it left).
  // The least round trip seen: the smoothed one includes the queue at a capped link, which a
  // lag limit that grew with it would let grow without bound.
  uint32_t minRoundTripUs = std::numeric_limits<uint32_t>::max();
  Clock::duration lagLimit() {
    if (const uint32_t rtt = peer.roundTripUs(); rtt > 0) {
      minRoundTripUs = std::min(minRoundTripUs, rtt);
    }
    const uint32_t rtt = minRoundTripUs == std::numeric_limits<uint32_t>::max() ? 0 : minRoundTripUs;
    return kStreamLag + 2 * std::chrono::microseconds(rtt);
  }

  static uint64_t microsecondsSince(Clock::time_point start) {
    return static_cast<uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start).count());
  }

  // A video stream's next chunks (SharedFrames::nextVideo), in one write, numbered on.
  bool writeVideo(httplib::DataSink& sink,
                  const std::vector<SharedFrames::VideoFramePtr>& frames) {
    std::string bytes;
    for (const SharedFrames::VideoFramePtr& frame : frames) {
      if (container) {
        const auto* data = reinterpret_cast<const uint8_t*>(frame->payload.data());
        bytes += container->frame({data, frame->payload.size()}, frame->key, frame->timestampUs);
        ++sequence;
        continue;
      }
      chunk.kind = frame->key ? protocol::video_chunk::kKey : protocol::video_chunk::kDelta;
      chunk.width = frame->width;
      chunk.height = frame->height;
      chunk.sequence = static_cast<uint32_t>(++sequence);
      chunk.timestampUs = frame->timestampUs;
      chunk.version = frame->version;
      chunk.time = frame->time;
      chunk.encodeUs = frame->encodeUs;
      bytes += videoChunk(chunk, frame->payload);
    }
    return write(sink, bytes);
  }

  // A stream that ends with a frame submitted ahead gives it up: not rendered unless it already
  // started, and then waited for, so stats count every render.
  void settleAhead() {
    if (!ahead) return;
    *ahead->drop = true;
    try {
      collectSessionFrame(context, session, *ahead);
    } catch (const std::exception&) {
      // Dropped, the session closed, or the frame failed: nobody is waiting for it.
    }
    ahead.reset();
  }

  bool writePart(httplib::DataSink& sink) {
    if (video) {
      // A video stream re-sends no picture (a delta frame only decodes once): a keep-alive
      // chunk says the stream is alive and nothing changed; in a standard container, bytes
      // every player skips (a WebM Void element, an MP4 free box).
      if (container) return write(sink, container->keepAlive());
      VideoChunk keepAlive = chunk;
      keepAlive.kind = protocol::video_chunk::kKeepAlive;
      keepAlive.timestampUs = microsecondsSince(video->channel->startedAt);
      keepAlive.encodeUs = 0;
      return write(sink, videoChunk(keepAlive, {}));
    }
    return write(sink, multipartPart(contentType, image, sequence, !wroteAny, interactiveScale));
  }

  // Why a stream ends without its client asking.
  using End = StreamEnd;

  // Whether the stream must end now, given the wall clock in Unix seconds. session->mutex held.
  End endNow(int64_t nowUnix) const {
    if (!slot || registry.stopping() || slot->replaced()) return End::quietly;
    return credentialEndNow(*session, credential, nowUnix);
  }

  // When a viewer token's stream must wake to end, on the steady clock its waits use (the token's
  // expiry is wall-clock time, as authorize() compares it).
  Clock::time_point viewerExpiry() const {
    // Further off than the next re-send it changes no wait (and cannot overflow the clock).
    if (credential.expiresAtUnix - unixNow() > kIdleResend.count() + 1) {
      return Clock::time_point::max();
    }
    const auto left = std::chrono::system_clock::from_time_t(time_t(credential.expiresAtUnix)) -
                      std::chrono::system_clock::now();
    return Clock::now() + std::chrono::duration_cast<Clock::duration>(left);
  }

  Problem problemOf(End end) const {
    const std::string id = quoteClientText(session->id);
    const std::string askOwner = "; ask the session's owner for a new one.";
    switch (end) {
      case End::sessionDeleted:
        return notFoundDetail("The session " + id + " was deleted.");
      case End::sessionExpired:
        return notFoundDetail("The session " + id + " expired: it was unused for longer than the "
                              "server's idle limit (sessionIdleSeconds).");
      case End::viewerRevoked:
        return unauthorized("The viewer link to " + id + " was revoked" + askOwner);
      case End::viewerExpired:
        return unauthorized("The viewer link to " + id + " expired" + askOwner);
      case End::none:
      case End::quietly:
        break;
    }
    return internalError("The stream of " + id + " ended.");
  }

  // Ends the response: an image stream's last part says why (when `end` has a reason), then the
  // terminating chunk, so the client sees a complete body and end of file; by then the stream's
  // place is free (a client that sees its stream end may open another at once). Returns false,
  // the provider's "nothing more". Called without session->mutex (write() takes it).
  bool finish(httplib::DataSink& sink, End end) {
    if (!video && end != End::none && end != End::quietly) {
      if (!write(sink, problemPart(problemOf(end), !wroteAny))) return false;
    }
    settleAhead();
    slot.reset();
    sink.done();
    return false;
  }

  // One provider call: waits for something to send, sends one part, returns. False ends the
  // response (after done() when it ends cleanly) and closes the connection.
  bool next(httplib::DataSink& sink);
};

bool StreamState::next(httplib::DataSink& sink) {
  for (;;) {
    End ending = End::none;
    bool animate = false;
    uint64_t version = 0;
    bool ended = false;  // the newest change ends its interaction (X-Myriad-Interaction: end)
    bool temporal = false;  // antialias=taa: frames of the stream's own, refined while still
    {
      std::lock_guard lock(session->mutex);
      temporal = session->scene.settings().antialias == render::Antialias::Taa;
      ending = endNow(unixNow());
      animate = session->scene.moving();  // lights animate or the scene clock plays a clip
      version = session->version;
      ended = session->interactionEndVersion == version;
    }
    if (ending != End::none) return finish(sink, ending);
    // A client that hung up gets no more frames: without this check, the frame after the close
    // (and often one more: the first write to a closed peer succeeds) was rendered for nobody.
    if (peer.gone()) return false;

    const Clock::time_point now = Clock::now();
    if (quality) {
      if (!hasFrame) {
        seenVersion = version;
      } else if (version != seenVersion) {
        quality->sawChange(now);
        seenVersion = version;
      }
    }
    // Interactive: the session changed within the settle time; a still is due once it settled.
    // A change that its client said ends the interaction needs no settle time: the still of it
    // is next. Straight away when the interaction has been showing (the last part was
    // interactive: a drag's release, a slider let go after moving); a change that ends an
    // interaction nobody has seen yet (a slider's single click) is shown once as an interactive
    // part first, quickly, and its still follows.
    // Animated lights change the picture every frame: the stream stays interactive while they
    // animate (at the animation's rate and scale), and the still follows once they stop.
    const bool endShown = ended && hasFrame && (version == shownVersion || lastInteractive);
    const bool steered = quality && hasFrame && quality->moving(now) && !endShown;
    const bool moving = steered || (quality && hasFrame && animate);
    const InteractiveQuality::Motion motion =
        steered ? InteractiveQuality::Motion::Steered : InteractiveQuality::Motion::Animated;
    const bool wantStill = quality && lastInteractive && !moving;
    // (Not a video stream: its channel renders for all its viewers, when the session changes.)
    const bool refining =
        temporal && !video && hasFrame && !moving && refineFrames < kTemporalRefineFrames;
    const bool wantFrame = !hasFrame || version != shownVersion || animate || wantStill || refining;
    // Delivery: a client more than lagLimit() behind gets no new frame until it catches up (the
    // newest state then, not the ones it missed: nothing queues in the kernel's buffers either),
    // and one that took nothing for kStreamWriteStall with bytes outstanding loses the stream
    // (its place and encoder go back). While behind, its link's rate is measured; a video
    // stream's channel bitrate is capped to it.
    const Lag lag = clientLag(now);
    if (lag.stalled) {
      std::fprintf(stderr, "myriad-server: stream of %s ended: its client took no byte for %lld s\n",
                   session->id.c_str(), static_cast<long long>(kStreamWriteStall.count()));
      return false;
    }
    const bool behind = wroteAny && lag.behind > lagLimit();
    if (behind && !behindSince) {
      behindSince.emplace(now, acked);
    } else if (behind && video && now - behindSince->first >= kStreamRateWindow) {
      const double seconds = std::chrono::duration<double>(now - behindSince->first).count();
      const double kbps = double(acked - behindSince->second) * 8.0 / 1000.0 / seconds;
      // Nothing taken meanwhile is a pause (or a client about to stall), not a link's rate.
      if (acked > behindSince->second) shared().capVideoBitrate(*video, static_cast<uint32_t>(kbps));
      behindSince.emplace(now, acked);
    } else if (!behind) {
      behindSince.reset();
    }
    if (wantFrame && behind) {
      // A frame rendered ahead would be stale by the time the client caught up: given up.
      settleAhead();
      std::unique_lock lock(session->mutex);
      session->changed.wait_until(lock, now + kStreamLagPoll, [&] {
        return endNow(unixNow()) != End::none;
      });
      continue;
    }
    // The still that ends an interaction is not held by the fps limit: it replaces the
    // interactive part just sent (a slider's click showed one, then its still follows at once).
    if (wantFrame && (now >= nextFrameAt || wantStill)) {
      SharedFrames::Frame frame;
      std::vector<SharedFrames::VideoFramePtr> videoFrames;
      std::string scaleText;   // the interactive frame's render scale
      try {
        // Streams of one session share renders (SharedFrames) unless this one pipelines: an
        // animated stream whose frames take longer than 1 / fps submits the next frame ahead,
        // which a shared render cannot (it would keep each stream's own frames in flight).
        // Video streams always share (their channel's encoder needs every frame in order).
        const bool pipelined = animate && (ahead || lastFrameTook >= interval);
        // A taa stream renders its own frames (its history is its own), not shared ones.
        const bool ownFrames = pipelined || temporal;
        if (!moving || motion != InteractiveQuality::Motion::Animated) animatedCollectedAt.reset();
        if (moving) {
          // A cheaper frame of the stream's own (its size is its own, so it is not shared); a
          // full frame submitted ahead is given up first (it would arrive slow and full).
          settleAhead();
          const double scale = quality->scale(motion);
          PendingSessionFrame pending = submitSessionFrame(
              context, session, quality->degrade(request, motion), render::FrameSource::Stream);
          SessionFrame own = collectSessionFrame(context, session, pending);
          const Clock::time_point collected = Clock::now();
          Clock::duration cost = collected - pending.submitted;
          // A gap longer than the frame itself is the fps limit's wait, not the write: left out.
          if (motion == InteractiveQuality::Motion::Animated && animatedCollectedAt &&
              pending.submitted - *animatedCollectedAt < cost) {
            cost += pending.submitted - *animatedCollectedAt;
          }
          quality->measured(motion, scale, cost);
          if (motion == InteractiveQuality::Motion::Animated) animatedCollectedAt = collected;
          // An interaction that ended while this part rendered (the drag released, the slider
          // let go) leaves it a picture nobody needs: its still is next. Not sent, so the client
          // does not decode it on the cores the still renders on, nor hold the still behind it.
          bool superseded = false;
          {
            std::lock_guard lock(session->mutex);
            superseded = motion == InteractiveQuality::Motion::Steered &&
                         !session->scene.settings().animate &&
                         session->interactionEndVersion > own.version;
          }
          if (superseded) {
            lastInteractive = true;
            continue;
          }
          frame = {std::make_shared<const EncodedFrame>(std::move(own.encoded)), own.version, 0};
          char text[32];
          auto [end, ec] = std::to_chars(text, text + sizeof text, scale);
          scaleText.assign(text, ec == std::errc() ? end : text);
        } else if (video) {
          const Clock::time_point start = Clock::now();
          videoFrames = shared().nextVideo(context, session, request, *video, interval,
                                           [this] { return peer.gone(); });
          lastFrameTook = Clock::now() - start;
        } else if (context.shared != nullptr && !ownFrames) {
          frame = context.shared->next(context, session, request, shownGeneration, interval);
          lastFrameTook = frame.took;
        } else {
          PendingSessionFrame pending =
              ahead ? std::move(*ahead)
                    : submitSessionFrame(context, session, request, render::FrameSource::Stream);
          ahead.reset();
          pending.frame.wait();
          // Rendered: the next one starts now and renders while this one is encoded and sent,
          // unless the client left while it rendered.
          if (animate && lastFrameTook >= interval && !peer.gone()) {
            ahead = submitSessionFrame(context, session, request, render::FrameSource::Stream);
          }
          SessionFrame own = collectSessionFrame(context, session, pending);
          lastFrameTook = Clock::now() - pending.submitted;
          frame = {std::make_shared<const EncodedFrame>(std::move(own.encoded)), own.version, 0};
        }
      } catch (const render::RenderQueueFullError&) {
        nextFrameAt = now + kQueueFullRetry;
        continue;
      } catch (const SharedFrames::ViewerGone&) {
        return false;  // the client left while its frame rendered: nothing to say to it
      } catch (const ProblemError&) {
        // The session closed while the frame rendered: said as at the top of the loop.
        {
          std::lock_guard lock(session->mutex);
          ending = endNow(unixNow());
        }
        return finish(sink, ending == End::none ? End::quietly : ending);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "myriad-server: stream of %s ended: frame failed: %s\n",
                     session->id.c_str(), e.what());
        sink.done();
        return false;
      }
      nextFrameAt = now + interval;
      if (quality && !moving) quality->measuredFull(lastFrameTook);
      lastInteractive = moving;
      interactiveScale = std::move(scaleText);
      hasFrame = true;
      if (video) {
        shownVersion = videoFrames.back()->version;
        return writeVideo(sink, videoFrames);
      }
      refineFrames = moving ? 0 : (frame.version == shownVersion ? refineFrames + 1 : 1);
      shownVersion = frame.version;
      shownGeneration = frame.generation;
      ++sequence;
      image = frame.encoded->body;
      contentType = frame.encoded->contentType;
      const Clock::time_point sendStart = Clock::now();
      const bool written = writePart(sink);
      const Clock::time_point sent = Clock::now();
      context.stats.recordSend(
          session, std::chrono::duration<double, std::milli>(sent - sendStart).count(),
          lastPartAt == Clock::time_point{}
              ? -1.0
              : std::chrono::duration<double, std::milli>(sent - lastPartAt).count());
      lastPartAt = sent;
      return written;
    }
    if (hasFrame && now - lastWriteAt >= kIdleResend) return writePart(sink);

    // Nothing to send yet: sleep until the fps limit allows the wanted frame, the re-send is due,
    // the viewer token expires, or the session changes, closes or loses the token (or shutdown
    // notifies), whichever comes first.
    Clock::time_point deadline = hasFrame ? lastWriteAt + kIdleResend : now + kIdleResend;
    if (wantFrame) deadline = std::min(deadline, nextFrameAt);
    if (quality && lastInteractive) deadline = std::min(deadline, quality->settlesAt());
    if (!credential.viewerHash.empty()) deadline = std::min(deadline, viewerExpiry());
    std::unique_lock lock(session->mutex);
    session->changed.wait_until(lock, deadline, [&] {
      return session->version != version || endNow(unixNow()) != End::none;
    });
  }
}

}  // namespace

StreamEnd credentialEndNow(const Session& session, const StreamCredential& credential,
                           int64_t nowUnix) {
  if (session.closed) {
    switch (session.closedBecause) {
      case Session::CloseReason::deleted: return StreamEnd::sessionDeleted;
      case Session::CloseReason::expired: return StreamEnd::sessionExpired;
      // Reloaded: the copy another server wrote answers the client's next stream. Shutdown:
      // the client cannot do anything with a reason.
      case Session::CloseReason::reloaded:
      case Session::CloseReason::shutdown: return StreamEnd::quietly;
    }
  }
  if (credential.viewerHash.empty()) return StreamEnd::none;
  for (const ViewerToken& viewer : session.viewerTokens) {
    if (!constantTimeEquals(viewer.hash, credential.viewerHash)) continue;
    return viewer.expiresAtUnix > nowUnix ? StreamEnd::none : StreamEnd::viewerExpired;
  }
  // Gone from the session: revoked, or dropped by a newer token after it expired.
  return credential.expiresAtUnix > nowUnix ? StreamEnd::viewerRevoked : StreamEnd::viewerExpired;
}

std::string multipartPart(std::string_view contentType, std::string_view image, uint64_t sequence,
                          bool first, std::string_view interactiveScale) {
  std::string part;
  part.reserve(image.size() + 160);
  if (first) part.append("--").append(protocol::kStreamBoundary).append("\r\n");
  part.append("Content-Type: ").append(contentType).append("\r\n");
  part.append("Content-Length: ").append(std::to_string(image.size())).append("\r\n");
  part.append(protocol::headers::kFrameSequence).append(": ");
  part.append(std::to_string(sequence)).append("\r\n");
  if (!interactiveScale.empty()) {
    part.append(protocol::headers::kInteractive).append(": ").append(interactiveScale).append("\r\n");
  }
  part.append("\r\n");
  part.append(image);
  part.append("\r\n--").append(protocol::kStreamBoundary).append("\r\n");
  return part;
}

std::string problemPart(const Problem& problem, bool first) {
  const std::string body = toBody(problem);
  std::string part;
  if (first) part.append("--").append(protocol::kStreamBoundary).append("\r\n");
  part.append("Content-Type: ").append(protocol::kProblemContentType).append("\r\n");
  part.append("Content-Length: ").append(std::to_string(body.size())).append("\r\n\r\n");
  part.append(body);
  part.append("\r\n--").append(protocol::kStreamBoundary).append("\r\n");
  return part;
}

std::string videoChunk(const VideoChunk& header, std::string_view payload) {
  std::string bytes(protocol::video_chunk::kHeaderBytes + payload.size(), '\0');
  auto put = [&](size_t offset, auto value) {
    // Little-endian on the wire; every machine Myriad builds for is little-endian (checked).
    static_assert(std::endian::native == std::endian::little);
    std::memcpy(bytes.data() + offset, &value, sizeof value);
  };
  put(0, static_cast<uint32_t>(payload.size()));
  put(4, header.kind);
  put(8, static_cast<uint16_t>(header.width));
  put(10, static_cast<uint16_t>(header.height));
  put(12, header.sequence);
  put(16, header.timestampUs);
  put(24, header.version);
  put(32, header.time);
  put(40, header.encodeUs);
  std::memcpy(bytes.data() + protocol::video_chunk::kHeaderBytes, payload.data(), payload.size());
  return bytes;
}

httplib::ContentProviderWithoutLength makeStreamProvider(const SessionFrameContext& context,
                                                         StreamRegistry& registry,
                                                         std::unique_ptr<StreamRegistry::Slot> slot,
                                                         SessionPtr session, FrameRequest request,
                                                         PeerWatch peer,
                                                         StreamCredential credential) {
  auto state = std::make_shared<StreamState>(StreamState{
      context, registry, std::move(slot), std::move(session), request,
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / request.fps)),
      peer, std::move(credential)});
  if (state->request.video) {
    encode::VideoSettings video;
    video.codec = state->request.video->codec;
    video.width = state->request.settings.width;
    video.height = state->request.settings.height;
    video.fps = state->request.fps;
    video.bitrateKbps = state->request.video->bitrateKbps;
    // The encoder's threads as encode::encoderThreadsFor chooses them for the host; a shared
    // SharedFrames with the server's encoder pool chooses again from the pool's size and the
    // encoders open (libvpx's VP8 threads spin-wait: at most one per 8 cores).
    video.threads = encode::encoderThreadsFor(
        video.codec, video.width, video.height,
        std::max(1u, std::thread::hardware_concurrency()), 0);
    if (state->context.shared == nullptr) state->ownShared = std::make_unique<SharedFrames>();
    state->video = state->shared().joinVideo(state->session, state->request, video);
    if (state->request.video->container != encode::VideoContainer::Myriad) {
      state->container = encode::makeContainerWriter(state->request.video->container, video.codec,
                                                     video.width, video.height, video.fps);
    }
  }
  if (state->request.interactiveFps > 0) state->quality.emplace(state->request.interactiveFps);
  // The renderer uses the key only while the session's antialias is taa (FrameSettings::
  // historyKey); the history goes when the stream ends.
  state->request.settings.historyKey = nextHistoryKey.fetch_add(1);
  return [state](size_t /*offset*/, httplib::DataSink& sink) {
    const bool more = state->next(sink);
    if (!more) {
      state->settleAhead();
      uint64_t sceneId = 0;
      {
        std::lock_guard lock(state->session->mutex);
        sceneId = state->session->sceneId;
      }
      state->context.renderThread.releaseHistory(static_cast<render::SceneId>(sceneId),
                                                 state->request.settings.historyKey);
      // The place goes back the moment the stream ends (a failed write included: a stalled
      // reader's frees it for the next stream), not whenever the HTTP layer destroys the response.
      state->slot.reset();
    }
    return more;
  };
}

namespace {

// One event stream's state, used only by the worker serving it.
struct EventStreamState {
  SessionPtr session;
  const StreamRegistry& registry;
  PeerWatch peer;
  StreamCredential credential;
  bool sentAny = false;
  uint64_t sentVersion = 0;
  Clock::time_point lastWriteAt = Clock::now();
  bool counted = false;  // holds one of session->eventStreams (set once in its shared_ptr)

  void release() {
    if (!counted) return;
    counted = false;
    registry.giveEventPlace();
    std::lock_guard lock(session->mutex);
    if (session->eventStreams > 0) --session->eventStreams;
  }
  ~EventStreamState() { release(); }

  // data: {"version": N, "role": "owner" | "viewer"} (the role of the token it was opened with:
  // a page opened from a link learns from it whether it may edit).
  std::string versionEvent(uint64_t version) const {
    const std::string_view role =
        credential.viewerHash.empty() ? protocol::roles::kOwner : protocol::roles::kViewer;
    return "event: version\ndata: {\"version\": " + std::to_string(version) + ", \"role\": \"" +
           std::string(role) + "\"}\n\n";
  }

  static const char* reasonOf(StreamEnd end) {
    switch (end) {
      case StreamEnd::sessionDeleted: return "deleted";
      case StreamEnd::sessionExpired:
      case StreamEnd::viewerExpired: return "expired";
      case StreamEnd::viewerRevoked: return "revoked";
      case StreamEnd::none:
      case StreamEnd::quietly: break;
    }
    return nullptr;
  }

  bool write(httplib::DataSink& sink, const std::string& bytes) {
    lastWriteAt = Clock::now();
    return sink.write(bytes.data(), bytes.size());
  }

  bool finish(httplib::DataSink& sink, StreamEnd end) {
    if (const char* reason = reasonOf(end)) {
      write(sink, std::string("event: end\ndata: {\"reason\": \"") + reason + "\"}\n\n");
    }
    release();
    sink.done();
    return false;
  }

  // One provider call: waits (at most kEventPoll) and writes what is due.
  bool next(httplib::DataSink& sink) {
    StreamEnd ending = StreamEnd::none;
    uint64_t version = 0;
    {
      std::unique_lock lock(session->mutex);
      if (sentAny) {
        const Clock::time_point deadline =
            std::min(Clock::now() + kEventPoll, lastWriteAt + kEventKeepAlive);
        session->changed.wait_until(lock, deadline, [&] {
          return session->version != sentVersion || registry.stopping() ||
                 credentialEndNow(*session, credential, unixNow()) != StreamEnd::none;
        });
      }
      ending = credentialEndNow(*session, credential, unixNow());
      version = session->version;
    }
    if (registry.stopping()) ending = StreamEnd::quietly;
    if (ending != StreamEnd::none) return finish(sink, ending);
    if (peer.gone()) {
      release();
      return false;
    }
    if (!sentAny || version != sentVersion) {
      sentAny = true;
      sentVersion = version;
      if (!write(sink, versionEvent(version))) return release(), false;
      return true;
    }
    if (Clock::now() - lastWriteAt >= kEventKeepAlive) {
      if (!write(sink, ": keep-alive\n\n")) return release(), false;
    }
    return true;
  }
};

}  // namespace

httplib::ContentProviderWithoutLength makeEventStreamProvider(SessionPtr session,
                                                              const StreamRegistry& registry,
                                                              PeerWatch peer,
                                                              StreamCredential credential) {
  auto state = std::make_shared<EventStreamState>(
      EventStreamState{std::move(session), registry, peer, std::move(credential)});
  state->counted = true;
  return [state](size_t /*offset*/, httplib::DataSink& sink) { return state->next(sink); };
}

}  // namespace myriad::service
