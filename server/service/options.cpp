#include "service/options.h"

#include <algorithm>
#include <charconv>
#include <functional>
#include <limits>
#include <vector>

namespace myriad::service {
namespace {

// A million lights is the design's upper end; far beyond that the light buffers outgrow what
// lavapipe can bind (128 MiB per storage buffer).
constexpr uint32_t kMaxLights = 1u << 20;
// Sizes beyond this are far past any Vulkan device's maxImageDimension2D.
constexpr uint32_t kMaxResolutionLimit = 65536;
constexpr uint32_t kMaxThreads = 256;
constexpr uint32_t kMaxQueuedFramesLimit = 1024;
// The light buffers of a session stay under lavapipe's 128 MiB storage-buffer range up to here.
constexpr uint32_t kMaxLightsPerSessionLimit = 1u << 22;
constexpr uint64_t kMaxBytesLimit = 1ull << 32;  // 4 GiB: far past any sane upload
constexpr uint32_t kMaxCountLimit = 1u << 16;    // sessions, streams, requests in flight
constexpr uint32_t kMaxIdleSeconds = 7 * 24 * 3600;

template <typename T>
T parseUnsigned(std::string_view flag, std::string_view text, T min, T max) {
  T value{};
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || value < min || value > max) {
    throw UsageError(std::string(flag) + " expects an integer from " + std::to_string(min) +
                     " to " + std::to_string(max) + ", not \"" + std::string(text) + "\".");
  }
  return value;
}

// A byte count with an optional binary or decimal suffix: "1073741824", "1GiB", "512MiB", "2G".
uint64_t parseBytes(std::string_view flag, std::string_view text, uint64_t min, uint64_t max) {
  static constexpr std::pair<std::string_view, uint64_t> kSuffixes[] = {
      {"KiB", 1ull << 10}, {"MiB", 1ull << 20}, {"GiB", 1ull << 30}, {"TiB", 1ull << 40},
      {"K", 1000ull},      {"M", 1000000ull},   {"G", 1000000000ull}, {"T", 1000000000000ull}};
  uint64_t unit = 1;
  std::string_view digits = text;
  for (const auto& [suffix, scale] : kSuffixes) {
    if (text.size() > suffix.size() && text.ends_with(suffix)) {
      digits = text.substr(0, text.size() - suffix.size());
      unit = scale;
      break;
    }
  }
  uint64_t value = 0;
  const char* end = digits.data() + digits.size();
  auto [ptr, ec] = std::from_chars(digits.data(), end, value);
  if (digits.empty() || ec != std::errc() || ptr != end || value > max / unit ||
      value * unit < min || value * unit > max) {
    throw UsageError(std::string(flag) + " expects a byte count from " + std::to_string(min) +
                     " to " + std::to_string(max) + " (suffixes KiB, MiB, GiB), not \"" +
                     std::string(text) + "\".");
  }
  return value * unit;
}

struct Flag {
  std::string_view name;
  bool takesValue;
  std::function<void(Options&, std::string_view)> apply;
};

const std::vector<Flag>& flags() {
  static const std::vector<Flag> table = {
      {"--host", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--host expects an address, not an empty string.");
         o.host = v;
       }},
      {"--port", true,
       [](Options& o, std::string_view v) {
         o.port = parseUnsigned<uint16_t>("--port", v, 0, 65535);
       }},
      {"--device", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--device expects a device index or name.");
         o.device = v;
       }},
      {"--validate", false, [](Options& o, std::string_view) { o.validate = true; }},
      {"--model", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--model expects a file path.");
         o.model = std::string(v);
       }},
      {"--lights", true,
       [](Options& o, std::string_view v) {
         o.lights = parseUnsigned<uint32_t>("--lights", v, 0, kMaxLights);
       }},
      {"--seed", true,
       [](Options& o, std::string_view v) {
         o.seed = parseUnsigned<uint64_t>("--seed", v, 0, std::numeric_limits<uint64_t>::max());
       }},
      {"--technique", true,
       [](Options& o, std::string_view v) {
         std::optional<render::Technique> t = render::parseTechnique(v);
         if (!t) {
           throw UsageError("--technique expects " + render::techniqueChoices() + ", got \"" +
                            std::string(v) + "\".");
         }
         o.technique = *t;
       }},
      {"--max-resolution", true,
       [](Options& o, std::string_view v) {
         o.maxResolution = parseUnsigned<uint32_t>("--max-resolution", v, 1, kMaxResolutionLimit);
       }},
      {"--threads", true,
       [](Options& o, std::string_view v) {
         o.threads = parseUnsigned<uint32_t>("--threads", v, 1, kMaxThreads);
       }},
      {"--encode-threads", true,
       [](Options& o, std::string_view v) {
         o.encodeThreads = parseUnsigned<uint32_t>("--encode-threads", v, 1, kMaxThreads);
       }},
      {"--max-connections", true,
       [](Options& o, std::string_view v) {
         o.maxConnections = parseUnsigned<uint32_t>("--max-connections", v, 16, kMaxCountLimit);
       }},
      {"--max-connections-per-client", true,
       [](Options& o, std::string_view v) {
         o.maxConnectionsPerClient =
             parseUnsigned<uint32_t>("--max-connections-per-client", v, 1, kMaxCountLimit);
       }},
      {"--header-timeout", true,
       [](Options& o, std::string_view v) {
         o.headerTimeoutSeconds = parseUnsigned<uint32_t>("--header-timeout", v, 1, 600);
       }},
      {"--max-queued-frames", true,
       [](Options& o, std::string_view v) {
         o.maxQueuedFrames =
             parseUnsigned<uint32_t>("--max-queued-frames", v, 0, kMaxQueuedFramesLimit);
       }},
      {"--max-frame-seconds", true,
       [](Options& o, std::string_view v) {
         o.maxFrameSeconds = parseUnsigned<uint32_t>("--max-frame-seconds", v, 0, 86400);
       }},
      {"--frames-in-flight", true,
       [](Options& o, std::string_view v) {
         o.framesInFlight = parseUnsigned<uint32_t>("--frames-in-flight", v, 1, 4);
       }},
      {"--overlap-frames", false, [](Options& o, std::string_view) { o.overlapFrames = true; }},
      {"--copy-frames", false, [](Options& o, std::string_view) { o.copyFrames = true; }},
      {"--rgba-jpeg", false, [](Options& o, std::string_view) { o.rgbaJpeg = true; }},
      {"--gpu-timestamps", true,
       [](Options& o, std::string_view v) {
         if (v == "passes") {
           o.gpuTimestamps = render::GpuTimestamps::Passes;
         } else if (v == "frame") {
           o.gpuTimestamps = render::GpuTimestamps::Frame;
         } else if (v == "none") {
           o.gpuTimestamps = render::GpuTimestamps::None;
         } else {
           throw UsageError("--gpu-timestamps expects passes, frame or none, got \"" +
                            std::string(v) + "\".");
         }
       }},
      {"--gbuffer", true,
       [](Options& o, std::string_view v) {
         const std::optional<render::GBufferPath> path = render::parseGBufferPath(v);
         if (!path) {
           throw UsageError("--gbuffer must be raster, compute or auto, not \"" + std::string(v) +
                            "\".");
         }
         o.gbuffer = *path;
       }},
      {"--tune", true,
       [](Options& o, std::string_view v) {
         try {
           render::applyTune(o.tuning, v);
         } catch (const render::TuningError& e) {
           throw UsageError(e.what());
         }
       }},
      {"--max-sessions", true,
       [](Options& o, std::string_view v) {
         o.maxSessions = parseUnsigned<uint32_t>("--max-sessions", v, 1, kMaxCountLimit);
       }},
      {"--max-lights", true,
       [](Options& o, std::string_view v) {
         o.maxLightsPerSession =
             parseUnsigned<uint32_t>("--max-lights", v, 1, kMaxLightsPerSessionLimit);
       }},
      {"--max-objects", true,
       [](Options& o, std::string_view v) {
         o.maxObjectsPerSession = parseUnsigned<uint32_t>("--max-objects", v, 1, 10000000);
       }},
      {"--max-memory", true,
       [](Options& o, std::string_view v) {
         o.maxMemoryBytes = parseBytes("--max-memory", v, 64ull << 20, 1ull << 50);
       }},
      {"--max-upload-bytes", true,
       [](Options& o, std::string_view v) {
         o.maxUploadBytes = parseUnsigned<uint64_t>("--max-upload-bytes", v, 1, kMaxBytesLimit);
       }},
      {"--max-body-bytes", true,
       [](Options& o, std::string_view v) {
         o.maxBodyBytes = parseUnsigned<uint64_t>("--max-body-bytes", v, 64, kMaxBytesLimit);
       }},
      {"--max-streams", true,
       [](Options& o, std::string_view v) {
         o.maxStreams = parseUnsigned<uint32_t>("--max-streams", v, 0, kMaxCountLimit);
       }},
      {"--max-streams-per-session", true,
       [](Options& o, std::string_view v) {
         o.maxStreamsPerSession =
             parseUnsigned<uint32_t>("--max-streams-per-session", v, 1, kMaxCountLimit);
       }},
      {"--max-requests", true,
       [](Options& o, std::string_view v) {
         o.maxRequestsInFlight = parseUnsigned<uint32_t>("--max-requests", v, 1, kMaxCountLimit);
       }},
      {"--session-idle-seconds", true,
       [](Options& o, std::string_view v) {
         o.sessionIdleSeconds =
             parseUnsigned<uint32_t>("--session-idle-seconds", v, 1, kMaxIdleSeconds);
       }},
      {"--shutdown-grace", true,
       [](Options& o, std::string_view v) {
         o.shutdownGraceSeconds = parseUnsigned<uint32_t>("--shutdown-grace", v, 0, 3600);
       }},
      {"--models", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--models expects a directory.");
         o.modelsDir = std::string(v);
       }},
      {"--state-dir", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--state-dir expects a directory.");
         o.stateDir = std::string(v);
       }},
      {"--state-store", true,
       [](Options& o, std::string_view v) {
         if (!v.starts_with("postgresql://") && !v.starts_with("postgres://")) {
           throw UsageError("--state-store expects a PostgreSQL URL (postgresql://...).");
         }
         o.stateStore = std::string(v);
       }},
      {"--lease-ms", true,
       [](Options& o, std::string_view v) {
         o.leaseMs = parseUnsigned<uint32_t>("--lease-ms", v, 200, 600000);
       }},
      {"--state-retention-hours", true,
       [](Options& o, std::string_view v) {
         o.stateRetentionHours =
             parseUnsigned<uint32_t>("--state-retention-hours", v, 1, 24 * 3650);
       }},
      {"--node-id", true,
       [](Options& o, std::string_view v) {
         o.nodeId = parseUnsigned<uint32_t>("--node-id", v, 0, 255);
       }},
      {"--log-format", true,
       [](Options& o, std::string_view v) {
         if (v != "json" && v != "text") {
           throw UsageError("--log-format expects json or text, not \"" + std::string(v) + "\".");
         }
         o.jsonAccessLog = v == "json";
       }},
      {"--batch", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--batch expects a job spec file.");
         o.batchSpec = std::string(v);
       }},
      {"--index", true,
       [](Options& o, std::string_view v) {
         o.batchIndex = parseUnsigned<uint32_t>("--index", v, 0, 1000000);
       }},
      {"--out", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) throw UsageError("--out expects a directory.");
         o.batchOut = std::string(v);
       }},
      {"--api-key", true,
       [](Options& o, std::string_view v) {
         if (v.size() < 8) throw UsageError("--api-key expects a key of at least 8 characters.");
         o.apiKey = std::string(v);
       }},
      {"--cors-origin", true,
       [](Options& o, std::string_view v) {
         if (v.empty()) {
           throw UsageError("--cors-origin expects an origin (https://host:port) or *.");
         }
         o.corsOrigins.emplace_back(v);
       }},
      {"--help", false, [](Options& o, std::string_view) { o.help = true; }},
      {"-h", false, [](Options& o, std::string_view) { o.help = true; }},
  };
  return table;
}

}  // namespace

Options parseOptions(std::span<const std::string_view> args) {
  Options options;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string_view arg = args[i];
    std::string_view name = arg;
    std::optional<std::string_view> inlineValue;
    if (size_t eq = arg.find('='); arg.starts_with("--") && eq != std::string_view::npos) {
      name = arg.substr(0, eq);
      inlineValue = arg.substr(eq + 1);
    }

    const Flag* flag = nullptr;
    for (const Flag& f : flags()) {
      if (f.name == name) flag = &f;
    }
    if (flag == nullptr) {
      if (!arg.starts_with("-")) {
        throw UsageError("Unexpected argument \"" + std::string(arg) +
                         "\"; myriad-server takes only flags (see --help).");
      }
      throw UsageError("Unknown flag \"" + std::string(name) + "\" (see --help).");
    }

    if (!flag->takesValue) {
      if (inlineValue) {
        throw UsageError(std::string(name) + " takes no value, but was given \"" +
                         std::string(*inlineValue) + "\".");
      }
      flag->apply(options, {});
      continue;
    }
    if (!inlineValue) {
      // A following flag is not a value: "--model --validate" is a forgotten path.
      if (i + 1 >= args.size() || args[i + 1].starts_with("--")) {
        throw UsageError(std::string(name) + " needs a value.");
      }
      inlineValue = args[++i];
    }
    flag->apply(options, *inlineValue);
  }
  if (options.maxStreamsPerSession == 0) {
    options.maxStreamsPerSession = std::max(1u, (options.maxStreams + 1) / 2);
  }
  if (options.stateDir && options.stateStore) {
    throw UsageError("--state-dir and --state-store are two stores; give one.");
  }
  return options;
}

std::string usage() {
  return R"(Usage: myriad-server [flags]

Serves frames of a Vulkan deferred renderer over HTTP: sessions with their own model, camera,
materials and lights (protocol/reference.md), and the stateless GET /v1/frame.

  --host ADDR              address to listen on (default 127.0.0.1)
  --port N                 TCP port; 0 picks a free one (default 8080). The URL is printed on
                           stdout once the server listens.
  --device NAME|INDEX      Vulkan device by index or name substring (default: the best GPU,
                           else a CPU implementation such as lavapipe)
  --validate               enable Vulkan validation layers; /v1/info counts their messages
  --model PATH             render a model file (glTF, OBJ, ... anything Assimp reads) instead
                           of the built-in scene
  --lights N               local lights to generate (default 256, at most 1048576)
  --seed S                 seed for the generated lights (default 1)
  --technique T            local-light shading: )" + render::techniqueChoices() + R"(
                           (default )" + std::string(render::techniqueName(Options{}.technique)) + R"()
  --max-resolution N       largest frame width or height served (default 4096; also capped by
                           the device)
  --threads N              HTTP worker threads (default 32; keep well above --max-streams plus
                           --max-queued-frames: each stream and waiting frame holds one)
  --encode-threads N       video encoder pool threads, shared by every session's streams with
                           fair turns; an encoder's own threads (libvpx row-mt and tiles,
                           OpenH264 slices) come from this (default: the hardware threads)
  --max-memory BYTES       what requests may take the process to (1GiB, 512MiB, ...): larger
                           bodies, frames and light generations wait, then 503 + Retry-After,
                           or 413 when one could never fit (default: the cgroup's memory.max,
                           else 3/4 of RAM)
  --max-connections N      open connections (default 4096); at the limit the longest-waiting
                           idle or half-sent one is closed for a new one, else 503
  --max-connections-per-client N
                           the same, from one address (default 512)
  --header-timeout S       seconds a request's head may take to arrive whole; 408 after
                           (default 10)
  --max-queued-frames N    frame requests that may wait for the renderer; more get
                           503 + Retry-After (default 4)
  --max-frame-seconds S    renderer time one frame may take, its parts together; a frame
                           over it gets 413 (default 120; 0: no limit)
  --frames-in-flight N     frames the renderer keeps submitted to the GPU at once, 1-4: the
                           next is recorded while the GPU renders (default 2; 1: serial)
  --overlap-frames         let frames of different sessions overlap on the GPU (the next
                           frame's G-buffer while the previous one lights; experimental)
  --copy-frames            copy every frame's pixels out of GPU-visible memory on the render
                           thread (the path before; default: encoders read them in place)
  --rgba-jpeg              read JPEG frames back as RGBA and convert them on the CPU (the path
                           before; default: YCbCr 4:2:0 made on the GPU, 1.5 bytes a pixel)
  --gpu-timestamps MODE    how frames are timed on the GPU: passes (default: one timestamp per
                           pass), frame (two a frame: Server-Timing and stats show one pass,
                           "frame"), none (no GPU times reported)
  --gbuffer P              how G-buffers are made: raster, compute (triangles rasterised by
                           compute shaders where the scene's materials are opaque and untextured
                           and the device has 64-bit atomics; raster elsewhere) or auto
                           (default: compute where it qualifies, except on CPU devices)
  --tune KEY=VALUE         set one of the renderer's tuning knobs (repeatable; render/tuning.h,
                           benchmarks and diagnostics; the defaults are the product's):
)" + std::string(render::tuningKeys()) + R"(  --max-sessions N         sessions open at once; more get 429 (default 16)
  --max-lights N           local lights per session; more get 413 (default 1000000)
  --max-objects N          objects per session (POST .../objects); more get 413 (default 100000)
  --max-upload-bytes N     largest model upload (default 67108864, 64 MiB)
  --max-body-bytes N       largest JSON request body (default 1048576, 1 MiB)
  --max-streams N          open frame streams, server-wide; more get 429 (default 8)
  --max-streams-per-session N  streams one session may hold; more get 429 (default half of
                           --max-streams, rounded up)
  --max-requests N         requests handled at once; more get 429 (default 64)
  --session-idle-seconds S a session unused for S seconds is deleted (default 600)
  --shutdown-grace S       after SIGTERM/SIGINT, answer what finishes within S seconds, then exit
                           0 with the rest cut off (default 10)
  --models DIR             model files sessions may load by name (library:NAME)
  --state-dir DIR          keep every session's state in DIR (written atomically before the
                           response to each change; tokens as SHA-256 hashes) and restore a session
                           from it on its first request after a restart, expiry, or on another
                           server sharing DIR
  --state-store URL        keep sessions in PostgreSQL instead (postgresql://USER@HOST/DB, or
                           ?host=/socket/dir): servers on many machines share them, one owner
                           per session under a lease (docs/deploy.md); the password belongs in
                           ~/.pgpass or PGPASSWORD, not the URL (ps shows arguments)
  --lease-ms MS            how long a session's lease lasts unrenewed (default 1000): a crashed
                           node's sessions move to another within it; more where the store
                           may not answer for that long (a PostgreSQL failover)
  --state-retention-hours H  remove state files unused for H hours (default 168)
  --node-id N              this server's number (0-255) among several behind one front
                           (docs/deploy.md): session ids start with it, responses name it in
                           X-Myriad-Node
  --log-format json|text   the access log on stderr: one JSON object per request (default:
                           time, requestId, method, route, session, status, bytes, latencyMs,
                           node) or one short text line
  --batch SPEC             render frames of a job spec (a snapshot and a camera path) without
                           HTTP, then exit (docs/deploy.md "Batch rendering")
  --index I                the batch index: frames I*K .. I*K+K-1 of the path (default: the
                           environment's JOB_COMPLETION_INDEX, else 0)
  --out DIR                where batch frames go (default .)
  --api-key KEY            creating a session needs Authorization: Bearer KEY (also from the
                           environment variable MYRIAD_API_KEY)
  --cors-origin ORIGIN     allow browser pages from ORIGIN (repeatable; * for any)
  --help                   this text

Exit status: 0 after SIGINT/SIGTERM, 1 when the server cannot start (no device, model not
loadable, address in use), 2 for a bad flag.
)";
}

}  // namespace myriad::service
