// Frames, streams, stats, metrics and the web client: the routes that deliver pictures and numbers
// (api_frames.cpp). The rest of the API registers in api.h's functions.
#pragma once

#include <cstdint>

#include "render/frame.h"
#include "service/api.h"
#include "service/frame_query.h"
#include "service/metrics.h"
#include "service/session_frames.h"
#include "service/shared_frames.h"
#include "service/stream.h"

namespace myriad::service {

// What these routes keep between requests; owned by the HTTP server, outliving every request.
struct FrameServices {
  // `encodeThreads` 0: the host's hardware threads.
  explicit FrameServices(uint32_t maxStreams, uint32_t encodeThreads = 0)
      : streams(maxStreams), encodePool(encodeThreads), shared(&encodePool) {}

  Metrics metrics;
  FrameStatsBook stats;
  StreamRegistry streams;
  // Every video stream's encodes, fair between sessions (encode/encode_pool.h). Before `shared`:
  // its channels encode on it.
  encode::EncodePool encodePool;
  SharedFrames shared;  // streams of one session share renders
  FrameDefaults builtinDefaults;          // GET /v1/frame: the built-in scene's camera and bounds
  render::FrameSettings builtinLighting;  // its sun, ambient and background
};

// GET /v1/frame (stateless, built-in scene), GET /v1/sessions/{id}/frame, .../stream, .../stats,
// GET /metrics, GET / and GET /web/{file}.
void addFrameRoutes(Routes& routes, ApiContext& context, FrameServices& frames);

}  // namespace myriad::service
