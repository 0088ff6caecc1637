// myriad-server: parse flags, build the scene, start the render thread, serve HTTP until
// SIGINT/SIGTERM. The work lives in service/; this file only orders it and maps failures to exit
// statuses (2 bad flag, 1 cannot start, 0 clean shutdown).
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sys/resource.h>

#include "gpu/context.h"
#include "loader/library.h"
#include "loader/loader.h"
#include "render/render_thread.h"
#include "scene/model_loader.h"
#include "service/batch.h"
#include "service/http_server.h"
#include "service/memory_budget.h"
#include "service/options.h"
#include "service/startup.h"
#include "service/store_files.h"
#include "service/store_postgres.h"

namespace {

// Raises the open-file limit to what the system allows, so --max-connections can be honoured; the
// connection cap stays below it, with room for model files, the GPU driver and the state
// directory, and a smaller one is said.
uint32_t descriptorsFor(uint32_t maxConnections) {
  constexpr rlim_t kReserved = 256;
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0) return maxConnections;
  if (limit.rlim_cur < limit.rlim_max) {
    limit.rlim_cur = limit.rlim_max;
    setrlimit(RLIMIT_NOFILE, &limit);
    getrlimit(RLIMIT_NOFILE, &limit);
  }
  if (limit.rlim_cur == RLIM_INFINITY || limit.rlim_cur >= maxConnections + kReserved) {
    return maxConnections;
  }
  const auto allowed = static_cast<uint32_t>(std::max<rlim_t>(limit.rlim_cur, 2 * kReserved) - kReserved);
  std::fprintf(stderr,
               "myriad-server: --max-connections %u is more than the open-file limit allows; "
               "using %u\n",
               maxConnections, allowed);
  return allowed;
}

using namespace myriad;

int fail(const std::string& sentence) {
  std::fprintf(stderr, "myriad-server: %s\n", sentence.c_str());
  return 1;
}

// The session API's configuration: limits as /v1/info lists them, the key, CORS.
service::ApiConfig apiConfig(const service::Options& options, uint32_t maxResolution,
                             const render::RenderQueue& renderThread) {
  service::ApiConfig api;
  service::ApiLimits& limits = api.limits;
  limits.maxResolution = maxResolution;
  limits.maxQueuedFrames = renderThread.maxQueuedFrames();
  limits.maxSessions = options.maxSessions;
  limits.maxLightsPerSession = options.maxLightsPerSession;
  limits.maxObjectsPerSession = options.maxObjectsPerSession;
  limits.maxUploadBytes = options.maxUploadBytes;
  limits.maxBodyBytes = options.maxBodyBytes;
  limits.maxStreams = options.maxStreams;
  limits.maxStreamsPerSession = options.maxStreamsPerSession;
  limits.maxRequestsInFlight = options.maxRequestsInFlight;
  limits.sessionIdleSeconds = options.sessionIdleSeconds;
  limits.maxFrameSeconds = options.maxFrameSeconds;
  limits.maxMemoryBytes =
      options.maxMemoryBytes != 0 ? options.maxMemoryBytes : service::defaultMemoryLimit();
  api.apiKey = options.apiKey;
  // The environment keeps the key out of `ps` output; the flag wins when both are given.
  if (const char* key = std::getenv("MYRIAD_API_KEY"); !api.apiKey && key && *key) api.apiKey = key;
  api.corsOrigins = options.corsOrigins;
  api.defaultTechnique = options.technique;
  api.validation = options.validate;
  api.builtinLights = options.lights;
  api.builtinSeed = options.seed;
  api.borrowPixels = !options.copyFrames;
  api.yuvJpeg = !options.rgbaJpeg;
  return api;
}

int run(const service::Options& options, const sigset_t& shutdownSignals) {
  scene::Scene scene;
  try {
    scene = service::buildScene(options);
  } catch (const std::exception& e) {
    return fail(e.what());
  }

  std::unique_ptr<render::RenderThread> renderThread;
  try {
    renderThread = std::make_unique<render::RenderThread>(
        gpu::ContextOptions{options.validate, options.device, options.tuning.pipelineStatistics},
        scene, options.maxQueuedFrames, options.framesInFlight, options.overlapFrames,
        options.gpuTimestamps, options.gbuffer, options.tuning);
  } catch (const gpu::NoDeviceError& e) {
    return fail(e.what());
  } catch (const std::exception& e) {
    return fail(std::string("cannot start the renderer: ") + e.what());
  }
  renderThread->setFrameBudgetMilliseconds(1000.0 * options.maxFrameSeconds);
  const render::DeviceSummary& device = renderThread->device();
  std::fprintf(stderr, "myriad-server: rendering on %s\n", service::describeDevice(device).c_str());
  if (device.isCpu) {
    std::fprintf(stderr,
                 "myriad-server: WARNING: %s is a CPU implementation (lavapipe or similar); "
                 "expect software-rendering speed.\n",
                 device.name.c_str());
  }
  std::fprintf(stderr, "myriad-server: scene: %s, %zu instances, %zu lights%s\n",
               options.model ? options.model->c_str() : "built-in", scene.instances.size(),
               scene.lights.size(), options.validate ? "; validation layers on" : "");

  service::HttpConfig config;
  config.host = options.host;
  config.port = options.port;
  config.threads = options.threads;
  config.encodeThreads = options.encodeThreads;
  config.connections.maxConnections = descriptorsFor(options.maxConnections);
  config.connections.maxConnectionsPerClient = options.maxConnectionsPerClient;
  config.connections.headTimeout = std::chrono::seconds(options.headerTimeoutSeconds);
  config.maxResolution = std::min(options.maxResolution, renderThread->maxDimension());
  config.validation = options.validate;
  config.technique = options.technique;
  std::unique_ptr<loader::ModelLibrary> models;
  if (options.modelsDir) {
    try {
      models = std::make_unique<loader::ModelLibrary>(*options.modelsDir);
    } catch (const std::exception& e) {
      return fail(e.what());
    }
  }
  config.models = models.get();
  std::unique_ptr<service::StateStore> state;
  if (options.stateDir || options.stateStore) {
    // Read back no larger than this server writes: a record over that was not written by it.
    const service::StateLimits limits = service::stateLimitsFor(
        options.maxUploadBytes, options.maxLightsPerSession, options.maxObjectsPerSession);
    try {
      if (options.stateStore) {
        state = std::make_unique<service::PostgresStateStore>(*options.stateStore, limits);
      } else {
        state = std::make_unique<service::FileStateStore>(*options.stateDir, limits);
      }
    } catch (const std::exception& e) {
      return fail(e.what());
    }
    config.state = state.get();
    config.stateRetention = std::chrono::hours(options.stateRetentionHours);
    config.leaseTime = std::chrono::milliseconds(options.leaseMs);
  }
  config.nodeId = options.nodeId;
  config.jsonAccessLog = options.jsonAccessLog;
  config.api = apiConfig(options, config.maxResolution, *renderThread);
  if (options.batchSpec) {
    // No HTTP: the session code renders the job's frames, then the process exits.
    service::SessionManager sessions(1, std::chrono::seconds(options.sessionIdleSeconds),
                                     [&](service::Session& session) {
                                       if (session.sceneId != 0) {
                                         renderThread->destroyScene(session.sceneId).get();
                                       }
                                     });
    service::ApiContext context{config.api, *renderThread, sessions, models.get(), nullptr};
    service::BatchJob job{*options.batchSpec, 0, options.batchOut};
    if (options.batchIndex) {
      job.index = *options.batchIndex;
    } else if (const char* index = std::getenv("JOB_COMPLETION_INDEX"); index && *index) {
      job.index = uint32_t(std::strtoul(index, nullptr, 10));
    }
    int status = 0;
    try {
      const size_t frames = service::runBatch(context, job);
      std::fprintf(stderr, "myriad-server: batch index %u: %zu frames in %s\n", job.index,
                   frames, job.outDir.c_str());
    } catch (const service::ProblemError& e) {
      status = fail("batch: " + e.problem().detail);
    } catch (const std::exception& e) {
      status = fail(std::string("batch: ") + e.what());
    }
    sessions.closeAll();
    if (status == 0 && options.validate && renderThread->validationMessages() > 0) {
      status = fail("batch: " + std::to_string(renderThread->validationMessages()) +
                    " Vulkan validation messages (above).");
    }
    renderThread->stop();
    return status;
  }
  service::HttpServer server(config, *renderThread, scene);
  uint16_t port = 0;
  try {
    port = server.bind();
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  std::printf("Myriad listening on %s\n", service::serverUrl(options.host, port).c_str());
  std::fflush(stdout);

  // The signals are blocked in every thread (see main), so this thread alone receives them.
  std::atomic<bool> serving{true};
  std::atomic<bool> signalled{false};
  std::mutex servedMutex;
  std::condition_variable served;  // notified when serve() has returned
  std::thread signalWaiter([&] {
    int signal = 0;
    sigwait(&shutdownSignals, &signal);
    if (!serving) return;  // woken by main below, not by a user
    signalled = true;
    std::fprintf(stderr, "myriad-server: %s received, shutting down (grace %u s)\n",
                 signal == SIGINT ? "SIGINT" : "SIGTERM", options.shutdownGraceSeconds);
    server.stop();
    // A client that keeps its request open (a header line every few seconds, a stalled upload)
    // would hold the shutdown for as long as it likes; past the grace the process ends anyway,
    // as an orchestrator's SIGKILL would, but with status 0 and a line in the log.
    std::unique_lock lock(servedMutex);
    if (!served.wait_for(lock, std::chrono::seconds(options.shutdownGraceSeconds),
                         [&] { return !serving; })) {
      std::fprintf(stderr,
                   "myriad-server: requests still open after the %u s shutdown grace; exiting "
                   "without them\n",
                   options.shutdownGraceSeconds);
      std::fflush(stdout);
      std::fflush(stderr);
      std::_Exit(0);
    }
  });
  const bool stoppedCleanly = server.serve();
  {
    std::lock_guard lock(servedMutex);
    serving = false;
  }
  served.notify_all();
  // serve() also returns when listening fails; then the waiter is still waiting.
  if (!signalled) pthread_kill(signalWaiter.native_handle(), SIGTERM);
  signalWaiter.join();

  renderThread->stop();
  if (!stoppedCleanly) return fail("stopped serving: accepting connections failed.");
  std::fprintf(stderr, "myriad-server: stopped\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The model loader child is this executable re-executed; it exits inside this call.
  if (loader::runChildIfRequested(argc, argv)) return 0;
  std::vector<std::string_view> args(argv + 1, argv + argc);
  service::Options options;
  try {
    options = service::parseOptions(args);
  } catch (const service::UsageError& e) {
    std::fprintf(stderr, "myriad-server: %s\n", e.what());
    return 2;
  }
  if (options.help) {
    std::fputs(service::usage().c_str(), stdout);
    return 0;
  }

  // Blocked before any thread exists, so every thread inherits the mask and a shutdown signal can
  // only be taken by sigwait in the waiter thread, never interrupt a worker or the render thread.
  sigset_t shutdownSignals;
  sigemptyset(&shutdownSignals);
  sigaddset(&shutdownSignals, SIGINT);
  sigaddset(&shutdownSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &shutdownSignals, nullptr);

  return run(options, shutdownSignals);
}
