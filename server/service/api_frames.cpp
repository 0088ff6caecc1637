// GET /v1/frame, GET /v1/sessions/{id}/frame, .../stream, .../stats, GET /metrics and the web
// client. Workers parse, wait for the render thread and encode; they never touch Vulkan.
#include "service/api_frames.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <cstdint>
#include <cstdio>
#include <future>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "render/render_queue.h"
#include "scene/coverage.h"
#include "service/connection.h"
#include "service/peer_watch.h"
#include "service/session_frames.h"
#include "service/session_json.h"
#include "web_assets.h"

namespace myriad::service {
namespace {

// What a 503 suggests; a frame on lavapipe takes from tens of milliseconds to a few seconds.
constexpr int kRetryAfterSeconds = 1;

Problem problemOf(const FrameQueryError& e) {
  return e.unknownParameter() ? unknownParameter(e.parameter(), e.what())
                              : invalidParameter(e.parameter(), e.what());
}

template <typename Parse>
FrameRequest parsedQuery(Parse parse) {
  try {
    return parse();
  } catch (const FrameQueryError& e) {
    throw ProblemError(problemOf(e));
  }
}

Problem busy(const render::RenderQueueFullError& e) {
  Problem problem = serverBusy(std::string("The renderer is busy: ") + e.what() + ".");
  problem.retryAfterSeconds = kRetryAfterSeconds;
  return problem;
}

// How often a waiting frame request asks whether its client is still connected.
constexpr std::chrono::milliseconds kPeerCheck{100};

// Runs `deliver` (a frame's way through the renderer); a full render queue becomes 503 with
// Retry-After, a renderer or encoder failure 500 render-failed (logged), a ProblemError passes.
template <typename Deliver>
auto withFrameProblems(const std::string& what, Deliver deliver) -> decltype(deliver()) {
  try {
    return deliver();
  } catch (const render::RenderQueueFullError& e) {
    throw ProblemError(busy(e));
  } catch (const render::FrameDroppedError& e) {
    // Only for a client that went away: nobody reads this answer.
    throw ProblemError(serverBusy(std::string("The frame was dropped: ") + e.what()));
  } catch (const render::FrameBudgetError& e) {
    // Not transient: the same frame costs the same. Fewer pixels or lights, or another
    // technique, fit.
    throw ProblemError(limitExceeded(
        413, std::string(protocol::limits::kMaxFrameSeconds),
        std::string("The frame was stopped: ") + e.what() +
            " (maxFrameSeconds); ask for fewer pixels or lights, or another technique."));
  } catch (const ProblemError&) {
    throw;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-server: %s failed: %s\n", what.c_str(), e.what());
    throw ProblemError(renderFailed(std::string("The renderer failed: ") + e.what()));
  }
}

// A frame's memory at its peak (memory_budget.h): its targets, readback and encoded copies.
MemoryBudget::Reservation reserveFrame(const ApiContext& context, const FrameRequest& request) {
  const render::FrameSettings& s = request.settings;
  // A multi-target frame: each target read back besides the frame's own costs a raw frame's
  // (its readback region, the frame's copy, its array and its share of the body).
  const uint64_t perPixel = (s.raw ? memory_cost::kRawFrameBytesPerPixel
                                   : memory_cost::kEncodedFrameBytesPerPixel) +
                            s.alsoRead.size() * memory_cost::kRawFrameBytesPerPixel +
                            // taa and ssaa: their sub-frames and the host's resolve.
                            (!s.resolvedFromSubFrames() ? 0
                             : s.antialias == render::Antialias::Ssaa
                                 ? memory_cost::kSsaaExtraBytesPerPixel
                                 : memory_cost::kTaaExtraBytesPerPixel);
  const std::string targets =
      s.alsoRead.empty() ? "" : " " + std::to_string(s.alsoRead.size() + 1) + "-target";
  return reserveMemory(context, uint64_t(s.width) * s.height * perPixel + memory_cost::kFrameFixedBytes,
                       "a " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                           (s.raw ? " raw" : "") + targets + " frame");
}

void sendFrame(httplib::Response& res, EncodedFrame&& encoded) {
  for (auto& [name, value] : encoded.headers) res.set_header(name, value);
  // Frames depend on server state that can change between identical URLs.
  res.set_header("Cache-Control", "no-store");
  const std::string contentType = encoded.contentType;
  res.body = std::move(encoded.body);
  res.set_header("Content-Type", contentType);
}

// GET /v1/frame: the built-in scene, everything from the query.
void handleBuiltinFrame(const ApiContext& context, FrameServices& frames,
                        const httplib::Request& req, httplib::Response& res) {
  FrameRequest request =
      parsedQuery([&] { return parseFrameRequest(req.params, frames.builtinDefaults); });
  render::FrameSettings& settings = request.settings;
  settings.sun = frames.builtinLighting.sun;
  settings.ambient = frames.builtinLighting.ambient;
  settings.background = frames.builtinLighting.background;
  const MemoryBudget::Reservation memory = reserveFrame(context, request);

  DeliveredFrame delivered = withFrameProblems("frame", [&] {
    return deliverFrame(context.renderThread, frames.metrics, context.renderThread.defaultScene(),
                        request);
  });
  sendFrame(res, std::move(delivered.encoded));
}

void handleSessionFrame(const ApiContext& context, FrameServices& frames,
                        const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  FrameRequest request = parsedQuery(
      [&] { return parseSessionFrameQuery(req.params, context.config.limits.maxResolution); });
  const SessionFrameContext frameContext{context.renderThread, frames.stats, frames.metrics,
                                         nullptr, context.config.borrowPixels,
                                         context.config.yuvJpeg};
  {
    // The session's anti-aliasing (taa and ssaa cost more memory: reserveFrame).
    std::lock_guard lock(session->mutex);
    request.settings.antialias = session->scene.settings().antialias;
  }
  const MemoryBudget::Reservation memory = reserveFrame(context, request);
  SessionFrame frame = withFrameProblems("frame of " + session->id, [&] {
    PendingSessionFrame pending =
        submitSessionFrame(frameContext, session, request, render::FrameSource::Request);
    // A client that hangs up while its frame waits (or renders split: a heavy frame takes
    // minutes on a CPU device) gives the frame up: not started, or stopped at its next slice.
    // The socket is looked up only for a frame still waiting after kPeerCheck.
    std::optional<PeerWatch> peer;
    while (pending.frame.wait_for(kPeerCheck) != std::future_status::ready) {
      if (!peer) peer.emplace(req.local_addr, req.local_port, req.remote_addr, req.remote_port);
      if (peer->gone()) *pending.drop = true;
    }
    return collectSessionFrame(frameContext, session, pending);
  });
  sendFrame(res, std::move(frame.encoded));
}

// The image a label frame was taken through, from its intrinsics and pose.
scene::PinholeView pinholeViewOf(const protocol::Labels& labels) {
  glm::mat4 worldFromCamera(1.0f);
  for (int row = 0; row < 4; ++row) {
    for (int column = 0; column < 4; ++column) {
      worldFromCamera[column][row] = float(labels.worldFromCamera[row][column]);
    }
  }
  const protocol::FrameIntrinsics& k = labels.intrinsics;
  return {glm::inverse(worldFromCamera), float(k.fx), float(k.fy), float(k.cx), float(k.cy),
          float(k.near), float(k.far), uint32_t(labels.width), uint32_t(labels.height)};
}

// GET .../labels: an instance-id frame of the session's camera, summed per object.
void handleLabels(const ApiContext& context, FrameServices& frames, const httplib::Request& req,
                  httplib::Response& res) {
  SessionPtr session = requestSession();
  FrameRequest request = parsedQuery(
      [&] { return parseSessionFrameQuery(req.params, context.config.limits.maxResolution); });
  request.settings.target = render::Target::InstanceId;
  request.settings.raw = true;
  request.format = ImageFormat::Raw;
  const SessionFrameContext frameContext{context.renderThread, frames.stats, frames.metrics,
                                         nullptr, false, false};
  SessionFrame frame = withFrameProblems("labels of " + session->id, [&] {
    PendingSessionFrame pending =
        submitSessionFrame(frameContext, session, request, render::FrameSource::Request);
    return collectSessionFrame(frameContext, session, pending);
  });
  const EncodedFrame& encoded = frame.encoded;
  const uint32_t width = request.settings.width, height = request.settings.height;
  if (encoded.body.size() != size_t(width) * height * 4) {
    throw ProblemError(renderFailed("The label frame has the wrong size."));
  }
  protocol::Labels labels;
  labels.width = width;
  labels.height = height;
  for (const auto& [name, value] : encoded.headers) {
    if (name == protocol::headers::kIntrinsics) {
      labels.intrinsics = nlohmann::json::parse(value).get<protocol::FrameIntrinsics>();
    } else if (name == protocol::headers::kPose) {
      nlohmann::json::parse(value).at("worldFromCamera").get_to(labels.worldFromCamera);
    }
  }
  // Per object id: pixels and the box they span.
  std::map<uint32_t, protocol::ObjectLabel> byId;
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      uint32_t id = 0;
      std::memcpy(&id, encoded.body.data() + (size_t(y) * width + x) * 4, 4);
      if (id == 0) continue;
      auto [it, fresh] = byId.try_emplace(id);
      protocol::ObjectLabel& l = it->second;
      if (fresh) l = {id, 0, 0, {x, y, x + 1, y + 1}, std::nullopt};
      ++l.pixels;
      l.box = {std::min<uint64_t>(l.box[0], x), std::min<uint64_t>(l.box[1], y),
               std::max<uint64_t>(l.box[2], x + 1), std::max<uint64_t>(l.box[3], y + 1)};
    }
  }
  {
    // The semantic class and 3D box as the session has them now (an object deleted since the
    // frame rendered is left out).
    // With each its total pixels: its meshes rasterised alone on the CPU through the frame's
    // own intrinsics and pose (scene/coverage.h), within a triangle budget.
    auto lock = lockOpen(*session);
    const SceneGraph& graph = session->scene.graph();
    scene::CoverageCounter coverage(pinholeViewOf(labels));
    labels.classes = session->scene.semanticClasses();
    for (auto& [id, l] : byId) {
      if (!graph.objects().contains(id)) continue;
      const protocol::Object wire = toWire(session->scene, graph.object(id));
      l.semantic = graph.object(id).semantic;  // a class name's id
      l.bounds = wire.bounds;
      bool counted = true;
      for (const SceneGraph::PlacedMesh& placed : graph.placedMeshes(id)) {
        counted = counted && coverage.add(*placed.mesh, placed.transform);
      }
      const uint64_t total = coverage.take();
      if (counted) l.totalPixels = std::max(total, l.pixels);
      labels.objects.push_back(l);
    }
  }
  sendJson(res, labels);
}

// The token a stream's request carried, read as authorize() reads it (the header wins), and, for
// a viewer token, its hash and expiry: the stream ends when that token stops working.
StreamCredential streamCredential(const httplib::Request& req, const Session& session,
                                  Role role) {
  StreamCredential credential;
  if (role == Role::owner) return credential;
  const Credentials presented = credentialsOf(req);
  const std::optional<std::string> token = presented.authorization
                                               ? bearerToken(*presented.authorization)
                                               : presented.queryToken;
  if (!token) return credential;  // authorize() admitted none; not reached
  credential.viewerHash = sha256Hex(*token);
  std::lock_guard lock(session.mutex);
  for (const ViewerToken& viewer : session.viewerTokens) {
    if (constantTimeEquals(viewer.hash, credential.viewerHash)) {
      credential.expiresAtUnix = viewer.expiresAtUnix;
    }
  }
  // Revoked since authorize() (expiresAtUnix 0): the stream's first turn ends it as revoked.
  if (credential.expiresAtUnix == 0) credential.expiresAtUnix = INT64_MAX;
  return credential;
}

void handleStream(ApiContext& context, FrameServices& frames, const httplib::Request& req,
                  httplib::Response& res) {
  Role role = Role::owner;
  SessionPtr session = context.sessions.authorize(req.matches[1].str(), credentialsOf(req),
                                                  /*allowQueryToken=*/true, Role::viewer, &role);
  FrameRequest request = parsedQuery(
      [&] { return parseStreamQuery(req.params, context.config.limits.maxResolution); });
  const uint32_t share = context.config.limits.maxStreamsPerSession;
  StreamRegistry::Refusal refusal = StreamRegistry::Refusal::none;
  PeerWatch peer(req.local_addr, req.local_port, req.remote_addr, req.remote_port);
  std::unique_ptr<StreamRegistry::Slot> slot = frames.streams.open(session, share, peer, &refusal);
  switch (refusal) {
    case StreamRegistry::Refusal::none:
      break;
    case StreamRegistry::Refusal::stopping:
      throw ProblemError(serverBusy("The server is shutting down."));
    case StreamRegistry::Refusal::maxStreamsPerSession:
      throw ProblemError(limitExceeded(
          429, std::string(protocol::limits::kMaxStreamsPerSession),
          "The session " + quoteClientText(session->id) + " already has " +
              std::to_string(share) +
              " streams open, its share of the server's (--max-streams-per-session); close one "
              "or retry later."));
    case StreamRegistry::Refusal::maxStreams:
      throw ProblemError(limitExceeded(
          429, "maxStreams",
          "This server already serves " + std::to_string(frames.streams.maxStreams()) +
              " streams, its limit (--max-streams); close one or retry later."));
  }
  // A reader that stops reading must not keep its place: its writes fail after this long without
  // progress, which ends the stream (stream.h).
  connection::setWriteStallLimit(kStreamWriteStall);
  res.set_header("Cache-Control", "no-store");
  std::string contentType(protocol::kStreamContentType);
  if (request.video) {
    switch (request.video->container) {
      case encode::VideoContainer::Myriad: contentType = protocol::kVideoStreamContentType; break;
      case encode::VideoContainer::Webm: contentType = protocol::kWebmContentType; break;
      case encode::VideoContainer::Mp4: contentType = protocol::kMp4ContentType; break;
    }
    res.set_header(std::string(protocol::headers::kVideoCodec),
                   encode::webCodecsName(request.video->codec, request.settings.width,
                                         request.settings.height, request.fps,
                                         request.video->bitrateKbps));
  }
  StreamCredential credential = streamCredential(req, *session, role);
  res.set_chunked_content_provider(
      contentType,
      makeStreamProvider({context.renderThread, frames.stats, frames.metrics, &frames.shared,
                          context.config.borrowPixels, context.config.yuvJpeg},
                         frames.streams, std::move(slot), std::move(session), std::move(request),
                         peer, std::move(credential)));
}

// GET .../events: Server-Sent Events of the session's version (stream.h). No stream slot; at most
// kMaxEventStreamsPerSession per session, since each holds a worker thread.
void handleEvents(ApiContext& context, FrameServices& frames, const httplib::Request& req,
                  httplib::Response& res) {
  Role role = Role::owner;
  SessionPtr session = context.sessions.authorize(req.matches[1].str(), credentialsOf(req),
                                                  /*allowQueryToken=*/true, Role::viewer, &role);
  StreamCredential credential = streamCredential(req, *session, role);
  if (frames.streams.stopping()) throw ProblemError(serverBusy("The server is shutting down."));
  {
    std::lock_guard lock(session->mutex);
    if (session->eventStreams >= kMaxEventStreamsPerSession) {
      throw ProblemError(limitExceeded(
          429, std::string(protocol::limits::kMaxEventStreamsPerSession),
          "The session " + quoteClientText(session->id) + " already has " +
              std::to_string(kMaxEventStreamsPerSession) +
              " event streams open, the most it may; close one or retry later."));
    }
    if (!frames.streams.takeEventPlace(kMaxEventStreams)) {
      throw ProblemError(limitExceeded(
          429, std::string(protocol::limits::kMaxEventStreams),
          "This server already serves " + std::to_string(kMaxEventStreams) +
              " event streams, the most it may; retry later (the page works without one)."));
    }
    ++session->eventStreams;
  }
  // Counted from here; the provider gives the place back when the stream ends.
  connection::setWriteStallLimit(std::chrono::seconds(3));
  res.set_header("Cache-Control", "no-store");
  PeerWatch peer(req.local_addr, req.local_port, req.remote_addr, req.remote_port);
  res.set_chunked_content_provider(
      std::string(protocol::kEventStreamContentType),
      makeEventStreamProvider(std::move(session), frames.streams, peer, std::move(credential)));
}

void handleStats(const ApiContext& /*context*/, FrameServices& frames, const httplib::Request& /*req*/,
                 httplib::Response& res) {
  SessionPtr session = requestSession();
  uint64_t lightCount = 0;
  bool animated = false;
  {
    auto lock = lockOpen(*session);
    lightCount = session->scene.lightCount();
    animated = session->scene.settings().animate;
  }
  sendJson(res, nlohmann::json(frames.stats.statsOf(*session, lightCount, animated)));
}

void handleMetrics(const ApiContext& context, FrameServices& frames, const httplib::Request& /*req*/,
                   httplib::Response& res) {
  MetricGauges gauges;
  gauges.sessions = context.sessions.count();
  gauges.streams = frames.streams.count();
  gauges.gpuMemoryBytes = context.renderThread.gpuMemoryBytes();
  gauges.validationMessages = context.renderThread.validationMessages();
  gauges.sharedStreamFrames = frames.shared.sharedCount();
  gauges.videoEncodes = frames.shared.videoEncodeCount();
  gauges.videoEncoders = frames.shared.videoChannelCount();
  gauges.videoResyncs = frames.shared.videoResyncCount();
  gauges.videoEncodersCreated = frames.shared.videoEncodersCreated();
  gauges.videoEncodersFreed = frames.shared.videoEncodersFreed();
  const encode::EncodePool::Stats pool = frames.encodePool.stats();
  gauges.encodeThreads = pool.threads;
  gauges.encodeQueued = pool.queued;
  gauges.encodeRunning = pool.running;
  gauges.encodeBuckets = encode::EncodePool::kBuckets;
  gauges.encodeBucketCounts = pool.buckets;
  gauges.encodeJobs = pool.jobs;
  gauges.encodeSecondsSum = pool.secondsSum;
  gauges.encodeWaitSecondsSum = pool.waitSecondsSum;
  if (context.connectionCounts) {
    const ConnectionCounts connections = context.connectionCounts();
    gauges.connectionsOpen = connections.open;
    gauges.connectionsAccepted = connections.accepted;
    gauges.connectionsRefused = connections.refusedAtCap;
    gauges.connectionsEvicted = connections.evicted;
    gauges.headTimeouts = connections.headTimeouts;
    gauges.headsRefused = connections.headRefused;
  }
  if (context.memory != nullptr) {
    gauges.memoryReservedBytes = context.memory->reserved();
    gauges.memoryLimitBytes = context.memory->limit();
  }
  res.set_content(frames.metrics.exposition(gauges), std::string(protocol::kMetricsContentType));
}

// GET / and GET /web/{file}: the embedded web client. A query is ignored (cache busters).
void handleWebAsset(const httplib::Request& req, httplib::Response& res) {
  const web::Asset* asset = web::findAsset(req.path);
  if (asset == nullptr) {
    throw ProblemError(notFoundDetail("The web client has no file " + quoteClientText(req.path) +
                                      "."));
  }
  // The assets change only with the binary; a short cache still lets a restart show new ones.
  res.set_header("Cache-Control", "max-age=60");
  res.set_content(asset->body.data(), asset->body.size(), std::string(asset->contentType));
}

}  // namespace

void addFrameRoutes(Routes& routes, ApiContext& context, FrameServices& frames) {
  namespace r = protocol::routes;
  routes.add("GET", r::kFrame, [&](const httplib::Request& req, httplib::Response& res) {
    handleBuiltinFrame(context, frames, req, res);
  });
  routes.add("GET", r::kSessionFrame,
             [&](const httplib::Request& req, httplib::Response& res) {
               handleSessionFrame(context, frames, req, res);
             });
  // A stream holds its worker for as long as it runs; maxStreams bounds those, so they do not
  // also take places meant for short requests.
  RouteOptions streamOptions;
  streamOptions.countsInFlight = false;
  routes.add(
      "GET", r::kSessionStream,
      [&](const httplib::Request& req, httplib::Response& res) {
        handleStream(context, frames, req, res);
      },
      streamOptions);
  routes.add(
      "GET", r::kSessionEvents,
      [&](const httplib::Request& req, httplib::Response& res) {
        handleEvents(context, frames, req, res);
      },
      streamOptions);
  routes.add("GET", r::kSessionLabels,
             [&](const httplib::Request& req, httplib::Response& res) {
               handleLabels(context, frames, req, res);
             });
  routes.add("GET", r::kSessionStats,
             [&](const httplib::Request& req, httplib::Response& res) {
               handleStats(context, frames, req, res);
             });
  RouteOptions metricsOptions;
  metricsOptions.countsInFlight = false;  // a scrape must work when the server is saturated
  routes.add(
      "GET", r::kMetrics,
      [&](const httplib::Request& req, httplib::Response& res) {
        handleMetrics(context, frames, req, res);
      },
      metricsOptions);
  RouteOptions webOptions;
  webOptions.countsInFlight = false;  // a static file costs nothing
  routes.add("GET", r::kWebRoot, handleWebAsset, webOptions);
  routes.add("GET", r::kWebFile, handleWebAsset, webOptions);
}

}  // namespace myriad::service
