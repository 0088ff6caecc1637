#include "service/stream.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <optional>
#include <thread>
#include <utility>

#include "service/interactive_quality.h"
#include "service/shared_frames.h"

namespace myriad::service {
namespace {

// How long a stream waits before retrying when the render queue refuses its frame. A stream's
// frames are not counted against --max-queued-frames (render::FrameSource::Stream), so this is
// only the render thread stopping, which the next turn of the loop sees.
constexpr std::chrono::milliseconds kQueueFullRetry{50};
// libvpx threads per video stream: 1080p at 30 fps needs about 4 on the GPU machine's cores.
constexpr unsigned kVideoEncoderThreads = 4;

// Everything one stream carries from part to part. Used only by the worker serving the stream.
struct StreamState {
  SessionFrameContext context;
  StreamRegistry& registry;
  std::unique_ptr<StreamRegistry::Slot> slot;
  SessionPtr session;
  FrameRequest request;
  Clock::duration interval;  // 1 / fps
  PeerWatch peer;            // the client's connection

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
  std::string interactiveScale;  // its render scale, as its part's X-Myriad-Interactive says

  // Video streams (request.video): the stream's place in its SharedFrames channel, whose encoder
  // it shares with every stream of the session asking for the same video.
  std::optional<SharedFrames::VideoViewer> video;
  std::unique_ptr<SharedFrames> ownShared;  // the channels when context.shared is null
  VideoChunk chunk;  // the header of the last chunk written

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
    return sink.write(bytes.data(), bytes.size());
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
      // chunk says the stream is alive and nothing changed.
      VideoChunk keepAlive = chunk;
      keepAlive.kind = protocol::video_chunk::kKeepAlive;
      keepAlive.timestampUs = microsecondsSince(video->channel->startedAt);
      keepAlive.encodeUs = 0;
      return write(sink, videoChunk(keepAlive, {}));
    }
    return write(sink, multipartPart(contentType, image, sequence, !wroteAny, interactiveScale));
  }

  // One provider call: waits for something to send, sends one part, returns. False ends the
  // response (after done() when it ends cleanly) and closes the connection.
  bool next(httplib::DataSink& sink);
};

bool StreamState::next(httplib::DataSink& sink) {
  for (;;) {
    bool closed = false;
    bool animate = false;
    uint64_t version = 0;
    bool ended = false;  // the newest change ends its interaction (X-Myriad-Interaction: end)
    {
      std::lock_guard lock(session->mutex);
      closed = session->closed;
      animate = session->scene.settings().animate;
      version = session->version;
      ended = session->interactionEndVersion == version;
    }
    if (closed || registry.stopping() || slot->replaced()) {
      // The terminating chunk, then close: the client sees a complete body and end of file.
      sink.done();
      return false;
    }
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
    const bool wantFrame = !hasFrame || version != shownVersion || animate || wantStill;
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
        if (moving) {
          // A cheaper frame of the stream's own (its size is its own, so it is not shared); a
          // full frame submitted ahead is given up first (it would arrive slow and full).
          settleAhead();
          const double scale = quality->scale(motion);
          PendingSessionFrame pending = submitSessionFrame(
              context, session, quality->degrade(request, motion), render::FrameSource::Stream);
          SessionFrame own = collectSessionFrame(context, session, pending);
          quality->measured(motion, scale, Clock::now() - pending.submitted);
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
          videoFrames = shared().nextVideo(context, session, request, *video, interval);
          lastFrameTook = Clock::now() - start;
        } else if (context.shared != nullptr && !pipelined) {
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
      } catch (const ProblemError&) {
        sink.done();  // the session closed while the frame rendered
        return false;
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
    // or the session changes or closes (or shutdown notifies), whichever comes first.
    Clock::time_point deadline = hasFrame ? lastWriteAt + kIdleResend : now + kIdleResend;
    if (wantFrame) deadline = std::min(deadline, nextFrameAt);
    if (quality && lastInteractive) deadline = std::min(deadline, quality->settlesAt());
    std::unique_lock lock(session->mutex);
    session->changed.wait_until(lock, deadline, [&] {
      return session->closed || registry.stopping() || slot->replaced() ||
             session->version != version;
    });
  }
}

}  // namespace

StreamRegistry::Slot::Slot(StreamRegistry& registry, SessionPtr session)
    : registry_(registry), session_(std::move(session)) {}

StreamRegistry::Slot::~Slot() {
  std::lock_guard lock(registry_.mutex_);
  registry_.open_.remove(this);
}

std::unique_ptr<StreamRegistry::Slot> StreamRegistry::open(SessionPtr session) {
  std::lock_guard lock(mutex_);
  if (stopping_) return nullptr;
  if (liveCount() >= maxStreams_) {
    auto oldest = std::find_if(open_.begin(), open_.end(), [&](const Slot* slot) {
      return !slot->replaced() && slot->session_ == session;
    });
    if (oldest == open_.end()) return nullptr;
    (*oldest)->replaced_ = true;
    // As in shutdown: the stream is either before its check (and sees the flag) or waiting.
    { std::lock_guard sessionLock(session->mutex); }
    session->changed.notify_all();
  }
  auto slot = std::make_unique<Slot>(*this, std::move(session));
  open_.push_back(slot.get());
  return slot;
}

uint32_t StreamRegistry::count() const {
  std::lock_guard lock(mutex_);
  return liveCount();
}

uint32_t StreamRegistry::liveCount() const {
  return static_cast<uint32_t>(
      std::count_if(open_.begin(), open_.end(), [](const Slot* slot) { return !slot->replaced(); }));
}

void StreamRegistry::shutdown() {
  std::lock_guard lock(mutex_);
  stopping_ = true;
  // Taking each session's mutex after setting the flag means a stream is either before its
  // predicate check (and sees the flag) or already waiting (and gets the notification).
  for (const Slot* slot : open_) {
    { std::lock_guard sessionLock(slot->session_->mutex); }
    slot->session_->changed.notify_all();
  }
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
                                                         PeerWatch peer) {
  auto state = std::make_shared<StreamState>(StreamState{
      context, registry, std::move(slot), std::move(session), request,
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / request.fps)),
      peer});
  if (state->request.video) {
    encode::VideoSettings video;
    video.codec = state->request.video->codec;
    video.width = state->request.settings.width;
    video.height = state->request.settings.height;
    video.fps = state->request.fps;
    video.bitrateKbps = state->request.video->bitrateKbps;
    // libvpx's VP8 threads spin-wait on each other: on a machine whose cores are busy (other
    // streams, a CPU renderer) 4 threads were 17x slower than 1 (949 against 57 ms a 1080p frame
    // on 2 shared cores). VP8 gets a thread per 4 cores; VP9's row-based threads block properly.
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    video.threads = std::clamp(video.codec == encode::VideoCodec::Vp8 ? cores / 4 : cores, 1u,
                               kVideoEncoderThreads);
    if (state->context.shared == nullptr) state->ownShared = std::make_unique<SharedFrames>();
    state->video = state->shared().joinVideo(state->session, state->request, video);
  }
  if (state->request.interactiveFps > 0) state->quality.emplace(state->request.interactiveFps);
  return [state](size_t /*offset*/, httplib::DataSink& sink) {
    const bool more = state->next(sink);
    if (!more) state->settleAhead();
    return more;
  };
}

}  // namespace myriad::service
