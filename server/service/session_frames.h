// One frame of a session, rendered from the session's state at the moment of the call and encoded
// as the request asks: the path GET .../frame and every part of GET .../stream share. Also the
// per-session record behind GET .../stats. Workers call this; it never touches Vulkan.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "protocol/types.h"
#include "render/frame.h"
#include "service/frame_query.h"
#include "service/metrics.h"
#include "render/render_queue.h"
#include "service/session.h"

namespace myriad::service {

// A frame's bytes as they go on the wire, with the headers that describe them.
struct EncodedFrame {
  std::string body;
  std::string contentType;
  double encodeMs = 0.0;
  // Server-Timing, X-Myriad-Technique, and for raw frames X-Myriad-Width/Height/Channels/Target.
  std::vector<std::pair<std::string, std::string>> headers;
};

// Encodes `frame` (rendered with request.settings) as request.format. Throws
// std::invalid_argument or an encoder's error when the frame does not match its settings.
EncodedFrame encodeFrame(const render::Frame& frame, const FrameRequest& request);

// A label frame (render::isLabel): raw, one little-endian uint32 a pixel (X-Myriad-Dtype: uint32);
// PNG or JPEG, a false-colour picture of the labels (0 black).
EncodedFrame encodeLabels(const render::Frame& frame, const FrameRequest& request);
// X-Myriad-Intrinsics and X-Myriad-Pose of a width x height frame through `camera`.
std::vector<std::pair<std::string, std::string>> cameraHeaders(const scene::Camera& camera,
                                                               uint32_t width, uint32_t height);
// A raw position or normal frame (frame.data, 4 floats a pixel, world space) in camera space
// (scene::worldFromCamera's axes): `points` for positions, else directions. Zero stays zero.
std::vector<float> inCameraSpace(std::span<const float> data, uint32_t width, uint32_t height,
                                 const scene::Camera& camera, bool points);
// A raw depth frame's z values (frame.data, 4 floats a pixel) as distances to the camera centre,
// in the same layout (the distance first of each pixel's 4 floats).
std::vector<float> depthAsDistance(std::span<const float> data, uint32_t width, uint32_t height,
                                   const scene::Camera& camera);

// The last frame of every open session, for GET .../stats, and where the time of its recent
// frames went (stats' `pipeline`: medians over the last kPipelineWindow frames of the last
// frame's size). Thread-safe.
class FrameStatsBook {
 public:
  static constexpr size_t kPipelineWindow = 128;
  // `waitMs`: how long the worker waited for the rendered frame.
  void record(const SessionPtr& session, const render::Frame& frame, render::Target target,
              double encodeMs, double waitMs = -1.0);
  // A stream part of the session written: how long the write took and the time since the
  // stream's previous part (negative for its first).
  void recordSend(const SessionPtr& session, double sendMs, double intervalMs);

  // The stats body; the light count and animation flag come from the session's current state.
  protocol::Stats statsOf(const Session& session, uint64_t lightCount, bool animated) const;

 private:
  // One frame's stages (render::FrameTimes plus the service's), for the medians.
  struct Times {
    double queueMs, recordMs, gpuMs, gpuIdleMs, fenceWaitMs, copyMs, answerMs, waitMs, encodeMs;
  };
  struct Entry {
    std::weak_ptr<Session> session;  // entries of sessions gone are dropped on the next record
    std::deque<Times> times;         // the last kPipelineWindow frames of the last size, oldest first
    std::deque<std::pair<double, double>> sends;  // stream parts' send and interval ms
    uint32_t timesWidth = 0, timesHeight = 0;
    protocol::FrameStats frame;
    protocol::CullingStats culling;
    protocol::LightShadowStats lightShadows;
    protocol::GpuMemory gpuMemory;
    uint64_t frames = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::string, Entry, std::less<>> entries_;
};

// Renders `request.settings` of scene `id` on the render thread, waits, encodes the frame as
// `request` asks and adds the time taken to myriad_frame_seconds: the path every frame takes.
// Throws render::RenderQueueFullError (queue full) and whatever the renderer or encoder threw.
struct DeliveredFrame {
  render::Frame frame;  // what the renderer returned (pixels included)
  EncodedFrame encoded;
};
DeliveredFrame deliverFrame(render::RenderQueue& renderThread, Metrics& metrics, render::SceneId id,
                            const FrameRequest& request,
                            render::FrameSource source = render::FrameSource::Request);

// A session frame as delivered: the encoded bytes and what it showed.
struct SessionFrame {
  EncodedFrame encoded;
  uint64_t version = 0;  // the session version the frame shows
  double time = 0.0;     // the animation time it shows, in seconds
};

// Encodes a rendered frame some other way than encodeFrame (a video stream's encoder).
using FrameEncoder = std::function<EncodedFrame(const render::Frame&)>;

class SharedFrames;

// What SessionFrames needs from the rest of the server.
struct SessionFrameContext {
  render::RenderQueue& renderThread;
  FrameStatsBook& stats;
  Metrics& metrics;
  // Streams take their frames through it (shared_frames.h), so that streams of one session
  // share renders; null: each stream renders its own.
  SharedFrames* shared = nullptr;
  // Frames' pixels stay in the renderer's readback memory until encoded
  // (render::FrameSettings::borrowPixels): no copy on the render thread.
  bool borrowPixels = false;
  // JPEG frames with subsampled chroma are read back as YCbCr 4:2:0 planes
  // (render::FrameSettings::yuv420) and encoded from them.
  bool yuvJpeg = false;
};

// A session frame submitted to the render thread and not yet collected (submitSessionFrame).
struct PendingSessionFrame {
  std::future<render::Frame> frame;
  // Set to give the frame up: not rendered if it has not started (render::FrameDroppedError).
  std::shared_ptr<std::atomic<bool>> drop = std::make_shared<std::atomic<bool>>(false);
  FrameRequest rendered;  // the request with the session's state applied
  uint64_t version = 0;   // the session version the frame shows
  Clock::time_point submitted;
};

// The two halves of renderSessionFrame, for a caller that overlaps one frame's encoding with the
// next frame's rendering (a stream): submit takes the session's state and queues the frame;
// collect waits for it, encodes it (with `encoder` when given, else as the request asks) and
// records it in stats and metrics. Same exceptions.
PendingSessionFrame submitSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                       const FrameRequest& request, render::FrameSource source);
SessionFrame collectSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                 PendingSessionFrame& pending,
                                 const FrameEncoder* encoder = nullptr);

// Takes the session's camera, settings and scene (under its mutex), renders on the render thread,
// waits, encodes, and records the frame in stats and metrics. `request.time` overrides the
// session's animation clock. Throws render::RenderQueueFullError (queue full), ProblemError 404 when the
// session closed meanwhile, and whatever the renderer or encoder threw.
// `source`: a stream's frames are not refused for a full queue (render::FrameSource).
SessionFrame renderSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                const FrameRequest& request,
                                render::FrameSource source = render::FrameSource::Request);

}  // namespace myriad::service
