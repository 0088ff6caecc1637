// The HTTP API (protocol/reference.md): routes, validation, problem responses, and the hand-off of
// frame requests to the render thread. Workers parse, wait and encode; they never touch Vulkan.
#pragma once

#include <chrono>
#include <optional>
#include <cstdint>
#include <memory>
#include <string>

#include "service/api.h"
#include "service/http_connections.h"
#include "render/render_queue.h"

namespace myriad::service {

struct HttpConfig {
  std::string host;
  uint16_t port = 0;  // 0 = any free port
  uint32_t threads = 8;
  uint32_t encodeThreads = 0;  // the video encoder pool's threads (encode/encode_pool.h); 0: host's
  // Bounds on connections and request heads (service/http_connections.h); `threads` sets its
  // workers.
  ConnectionLimits connections;
  uint32_t maxResolution = 4096;  // already capped by the renderer's maximum
  bool validation = false;
  render::Technique technique = render::Technique::Clustered;  // unless a request names one
  ApiConfig api;                                   // sessions: limits, key, CORS
  loader::ModelLibrary* models = nullptr;          // --models; must outlive the server
  // --state-dir or --state-store: sessions written there and restored from there
  // (service/state_store.h); null = sessions live in memory only. Must outlive the server.
  // Records not written for stateRetention are removed. Each session is served under a lease of
  // leaseTime (--lease-ms; service/lease.h).
  StateStore* state = nullptr;
  std::chrono::seconds stateRetention{std::chrono::hours(24 * 7)};
  std::chrono::milliseconds leaseTime{1000};
  // --node-id: session ids start with it and every response names it (X-Myriad-Node).
  std::optional<uint32_t> nodeId;
  // The access log's form (--log-format): JSON lines (AccessLog in http_server.cpp), else text.
  bool jsonAccessLog = true;
};

// What GET /v1/info reports about the scene; counted once at start-up.
struct SceneSummary {
  size_t lights = 0;
  size_t instances = 0;
  size_t materials = 0;
  size_t meshes = 0;
};

class HttpServer {
 public:
  // `renderThread` must outlive the server. `scene` supplies the default camera and bounds.
  HttpServer(const HttpConfig& config, render::RenderQueue& renderThread,
             const scene::Scene& scene);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds the listening socket and returns the port (the chosen one when config.port is 0).
  // Throws std::runtime_error with one sentence when the address cannot be bound.
  uint16_t bind();

  // Serves until stop(); returns after the requests in flight have been answered and the worker
  // threads joined. False when listening failed rather than being stopped.
  bool serve();

  // Callable from any thread, before or during serve(); serve() then returns.
  void stop();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace myriad::service
