// Command-line options of myriad-server, parsed without side effects so the rules are unit-tested.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "render/frame.h"
#include "render/tuning.h"

namespace myriad::service {

struct Options {
  std::string host = "127.0.0.1";    // loopback unless asked: the API has no authentication yet
  uint16_t port = 8080;              // 0 = any free port (the chosen one is printed)
  std::string device;                // "" = best device; else an index or a name substring
  bool validate = false;             // Vulkan validation layers, messages counted in /v1/info
  std::optional<std::string> model;  // a model file instead of the built-in scene
  uint32_t lights = 256;
  uint64_t seed = 1;
  // How local lights are shaded unless a request says otherwise. Clustered is the default: it is
  // the one whose cost stays flat from a handful of lights to a million (docs/performance.md).
  render::Technique technique = render::Technique::Clustered;
  // Upper bound on frame width and height; the effective bound is also capped by the device.
  uint32_t maxResolution = 4096;
  // HTTP worker threads. A worker waits while its frame renders and a stream holds one for as
  // long as it runs, so this must stay well above maxStreams + maxQueuedFrames + 1 for other
  // requests to stay answerable with every stream open and the render queue full.
  uint32_t threads = 32;
  // Video encoder pool threads, shared by every session's streams with fair turns
  // (encode/encode_pool.h). 0: the host's hardware threads.
  uint32_t encodeThreads = 0;
  // Connections (service/http_connections.h): open in all and from one address (the longest-waiting
  // idle or partial one gives way to a new one at the cap), and how long a request head may take.
  uint32_t maxConnections = 4096;
  uint32_t maxConnectionsPerClient = 512;
  uint32_t headerTimeoutSeconds = 10;
  // Frame requests allowed to wait for the render thread (besides the one rendering); more get
  // 503 + Retry-After. Each waiting frame holds a worker thread and, later, its pixels in memory.
  uint32_t maxQueuedFrames = 4;
  // The renderer time one frame may take, its bounded submissions together (render::Renderer's
  // split frames); a frame that took it, or whose parts measured so far say it will, is refused
  // with 413 limit-exceeded (maxFrameSeconds). 0: no limit. On lavapipe (2 cores) a 1920x1080
  // frame takes about 0.5 s and 4096x4096 3 s; 320x180 of a million clustered lights over a
  // minute, 1920x1080 of a million light volumes many minutes.
  uint32_t maxFrameSeconds = 120;
  // Frames the render thread keeps in flight on the GPU (render::Renderer's frame slots, 1..4):
  // it records and submits the next frame while the GPU renders and the previous one is read
  // back. 1: the serial path (submit, wait, read back, then the next).
  uint32_t framesInFlight = 2;
  // Frames of different sessions may overlap on the GPU (render::Renderer::setOverlap); off by
  // default until measured on a GPU.
  bool overlapFrames = false;
  // The render thread copies each frame's pixels out of the readback memory (the path before
  // issue 18's stop 14); default off: JPEG and PNG encoders read them where the GPU put them
  // (render::FrameSettings::borrowPixels), off the render thread.
  bool copyFrames = false;
  // GPU timestamps per pass, at frame boundaries only, or none (render::Renderer::setGpuTimestamps).
  render::GpuTimestamps gpuTimestamps = render::GpuTimestamps::Passes;
  // JPEG frames read back as RGBA and converted on the CPU by libjpeg (the path before stop 14);
  // default off: converted to YCbCr 4:2:0 on the GPU (render::FrameSettings::yuv420).
  bool rgbaJpeg = false;
  // How G-buffers are made (render::GBufferPath). Auto: in compute where the scene qualifies on a
  // GPU (on the H200 the floor scene's G-buffer took 0.24 ms instead of 1.34 at 1080p, 0.81
  // instead of 5.31 at 4K; docs/performance.md), raster on CPU devices, where raster is cheaper.
  render::GBufferPath gbuffer = render::GBufferPath::Auto;
  // The renderer's knobs (render/tuning.h), from repeatable --tune key=value flags.
  render::Tuning tuning;
  // Sessions (protocol/CONTRACT.md). Each holds a GPU scene, so the count is bounded.
  uint32_t maxSessions = 16;
  uint32_t maxLightsPerSession = 1000000;
  uint32_t maxObjectsPerSession = 100000;  // --max-objects
  // --max-memory (service/memory_budget.h); 0 until given: the cgroup's limit or 3/4 of RAM.
  uint64_t maxMemoryBytes = 0;
  uint64_t maxUploadBytes = 64ull << 20;  // PUT .../model file uploads
  uint64_t maxBodyBytes = 1ull << 20;     // every JSON body
  uint32_t maxStreams = 8;                // open GET .../stream connections, server-wide
  // Streams one session may hold, so that one client or one shared viewer link cannot take every
  // place. 0 until parseOptions resolves it: given, or half of maxStreams rounded up (at least
  // 1), which leaves the other half to at least one other session.
  uint32_t maxStreamsPerSession = 0;
  uint32_t maxRequestsInFlight = 64;      // requests being handled at once (429 beyond)
  uint32_t sessionIdleSeconds = 600;      // a session unused this long is deleted
  // After SIGINT/SIGTERM: requests that finish within this many seconds are answered; then the
  // process exits 0 with whatever is still open (a slow client must not hold a shutdown past
  // the orchestrator's own grace: Docker and Kubernetes SIGKILL after 10 and 30 s).
  uint32_t shutdownGraceSeconds = 10;
  std::optional<std::string> modelsDir;   // --models: the library of loadable model files
  std::optional<std::string> stateDir;    // --state-dir: sessions persisted there
  uint32_t stateRetentionHours = 168;     // --state-retention-hours: files kept this long unused
  // --state-store postgresql://...: sessions in PostgreSQL, shared by servers on many machines
  // (service/store_postgres.h); instead of --state-dir.
  std::optional<std::string> stateStore;
  // --lease-ms: a session's lease time (service/lease.h). 1000 so that a crashed node's sessions
  // answer from another within issue 33's 2 s: with 2000 the lease alone took up to 2 s and the
  // chaos test's crash gaps reached 2.5 s (p99); 1000 doubles the lease rows renewed (four
  // times a second per session), which the same test's PostgreSQL took without a change in
  // transactions per second (bench/results/lavapipe-2026-12-05-stop43/chaos-60s-*.json).
  uint32_t leaseMs = 1000;
  // --node-id N (0-255): this server's number among several behind one front. Session ids then
  // start with it ("s-" + 2 hex digits of N + 14 random ones) so the front routes a session's
  // requests to the node that made it, and every response names the node (X-Myriad-Node).
  std::optional<uint32_t> nodeId;
  // --log-format: one JSON object per request on stderr (json, the default) or the short line
  // "METHOD PATH -> STATUS (N bytes)" (text).
  bool jsonAccessLog = true;
  // --batch SPEC [--index I] [--out DIR]: render index I's frames of a job spec and exit
  // (service/batch.h); no HTTP. Without --index, the environment's JOB_COMPLETION_INDEX (a
  // Kubernetes Indexed Job's), else 0.
  std::optional<std::string> batchSpec;
  std::optional<uint32_t> batchIndex;
  std::string batchOut = ".";
  std::optional<std::string> apiKey;      // --api-key (or env MYRIAD_API_KEY, read by main)
  std::vector<std::string> corsOrigins;   // --cors-origin, repeatable
  bool help = false;
};

// A bad flag or value. what() is one sentence for stderr.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses the arguments after the program name. Accepts "--flag value" and "--flag=value"; a flag
// given twice takes its last value. Throws UsageError.
Options parseOptions(std::span<const std::string_view> args);

// The --help text.
std::string usage();

}  // namespace myriad::service
