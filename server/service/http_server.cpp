#include "service/http_server.h"

#include <httplib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <stdexcept>
#include <string_view>
#include <thread>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/openapi.h"
#include "service/api_frames.h"
#include "service/frame_query.h"
#include "service/problem.h"
#include "service/session_sync.h"

namespace myriad::service {
namespace {

// A 4096x4096 frame is tens of MiB of PNG; a slow client must still be able to take it.
constexpr time_t kWriteTimeoutSeconds = 30;

// Problems for the statuses httplib produces itself, before any handler runs.
Problem problemForStatus(int status, const httplib::Request& req, const ApiLimits& limits) {
  switch (status) {
    case 404:
      return notFound(req.path);
    case 413:
      // Only bodies without Content-Length get here (the route table refuses the others): they
      // are read up to the largest limit, the upload's.
      return limitExceeded(413, "maxUploadBytes",
                           "The request body is larger than " +
                               std::to_string(limits.maxUploadBytes) + " bytes.");
    case 414:
      return badRequest(414, "The request URI is too long.");
    default:
      if (status >= 500) return internalError("The server failed to handle the request.");
      // httplib refuses a POST/PUT/PATCH that says nothing of its body's length (curl -X POST
      // without -d does that); say so rather than blame the HTTP.
      if ((req.method == "POST" || req.method == "PUT" || req.method == "PATCH") &&
          !req.has_header("Content-Length") && !req.has_header("Transfer-Encoding")) {
        return badRequest(status, req.method +
                                      " needs a Content-Length header; an empty body is "
                                      "Content-Length: 0 (curl: -d '').");
      }
      return badRequest(status, "The request is not valid HTTP/1.1 for this server.");
  }
}

// The access log (--log-format). The request's start and id are per worker thread: httplib
// serves a request on one thread from routing to the log line.
struct RequestTrace {
  std::chrono::steady_clock::time_point start;
  bool started = false;
};
thread_local RequestTrace tTrace;

// A client's X-Request-Id is kept when it is 1-128 of [A-Za-z0-9._:-] (safe in logs and
// headers); anything else is replaced by one made here.
bool acceptableRequestId(std::string_view id) {
  if (id.empty() || id.size() > 128) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == ':' ||
           c == '-';
  });
}

std::string newRequestId() {
  static std::atomic<uint64_t> counter{0};
  static const uint64_t process = std::random_device{}();
  char text[40];
  std::snprintf(text, sizeof text, "%08llx-%012llx",
                static_cast<unsigned long long>(process & 0xffffffffu),
                static_cast<unsigned long long>(counter.fetch_add(1) + 1));
  return text;
}

std::string utcNow() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, int(millis));
  return text;
}

// One line per request, written once it was answered (a stream: once it ended, so latencyMs is
// its duration). Never the query string, headers or body: no token reaches the log. `route` is
// the template ("/v1/sessions/{id}/camera"; "unmatched" for none), `session` the id in the path.
void logRequest(const httplib::Request& req, const httplib::Response& res, const Routes& routes,
                bool json, const std::string& node) {
  std::string line;
  const std::string route = routes.routeOf(req.path, req.method);
  if (json) {
    nlohmann::json entry = {{"time", utcNow()},
                            {"requestId", res.get_header_value(std::string(protocol::headers::kRequestId))},
                            {"method", req.method},
                            {"route", route},
                            {"status", res.status},
                            {"bytes", res.body.size()}};
    if (route.starts_with(std::string(protocol::routes::kSession)) && req.matches.size() > 1) {
      entry["session"] = req.matches[1].str();
    }
    if (tTrace.started) {
      entry["latencyMs"] =
          std::round(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                               tTrace.start).count() * 1000.0) /
          1000.0;
    }
    if (!node.empty()) entry["node"] = node;
    line = entry.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  } else {
    line = req.method + " " + route + " -> " +
           std::to_string(res.status) + " (" + std::to_string(res.body.size()) + " bytes)\n";
  }
  tTrace.started = false;
  // One write per line keeps lines from concurrent workers whole.
  std::fwrite(line.data(), 1, line.size(), stderr);
}

}  // namespace

struct HttpServer::State {
  HttpConfig config;
  render::RenderQueue& renderThread;
  SceneSummary scene;
  BoundedHttpServer server;
  MemoryBudget memory;
  SessionManager sessions;
  ApiContext api;
  Routes routes;
  FrameServices frames;  // frames, streams, stats, metrics

  // The hand-shake between stop() and serve(); see stop().
  std::atomic<bool> stopRequested{false};  // also: GET /v1/ready says "draining"
  std::atomic<bool> serveEntered{false};
  std::atomic<bool> serveFinished{false};

  State(const HttpConfig& c, render::RenderQueue& r)
      : config(c),
        renderThread(r),
        server(connectionLimits(c), isProbe),
        memory(c.api.limits.maxMemoryBytes),
        sessions(c.api.limits.maxSessions, std::chrono::seconds(c.api.limits.sessionIdleSeconds),
                 [&r](Session& session) { releaseScene(r, session); }),
        api{c.api, r, sessions, c.models, c.state, &memory},
        routes(server, api),
        frames(c.api.limits.maxStreams, c.encodeThreads) {}

  static ConnectionLimits connectionLimits(const HttpConfig& c) {
    ConnectionLimits limits = c.connections;
    limits.workers = c.threads;
    return limits;
  }

  // Load balancers' and monitors' requests: served by workers of their own, so they answer
  // however many requests wait for the others.
  static bool isProbe(const http::RequestHead& head) {
    namespace r = protocol::routes;
    return (head.method == "GET" || head.method == "HEAD") &&
           (head.path == r::kHealth || head.path == r::kReady || head.path == r::kMetrics);
  }

  // A closed session's GPU scene, destroyed before the DELETE (or expiry) finishes.
  static void releaseScene(render::RenderQueue& renderThread, Session& session) {
    if (session.sceneId == 0) return;  // failed while being created: no scene yet
    try {
      renderThread.destroyScene(session.sceneId).get();
    } catch (const std::exception& e) {
      // Only at shutdown (the render thread has stopped and frees everything itself).
      std::fprintf(stderr, "myriad-server: session %s: scene not released: %s\n",
                   session.id.c_str(), e.what());
    }
  }

  void handleInfo(httplib::Response& res) const;

  // With a state store (session_sync.h): writes, leases, restores. Declared last: it is
  // destroyed first (flushing, giving back leases), while the sessions are still open.
  std::unique_ptr<SessionSync> sync;

  // GET /v1/openapi.json: built once, from protocol/ and the renderer's targets.
  const std::string openApi = protocol::openApiDocument({MYRIAD_VERSION, targetNames()}).dump(2);

  static std::vector<std::string_view> targetNames() {
    return {render::kTargetNames.begin(), render::kTargetNames.end()};
  }
};

void HttpServer::State::handleInfo(httplib::Response& res) const {
  nlohmann::json targets = nlohmann::json::array();
  for (std::string_view name : render::kTargetNames) targets.push_back(name);
  nlohmann::json techniques = nlohmann::json::array();
  for (std::string_view name : render::kTechniqueNames) techniques.push_back(name);
  nlohmann::json info = {
      {"server", {{"name", "myriad-server"}, {"version", MYRIAD_VERSION}}},
      {"device", nlohmann::json(renderThread.device())},
      {"limits", api.config.limits.toJson()},
      {"apiKeyRequired", api.config.apiKey.has_value()},
      {"formats", protocol::kFormats},
      {"sessions", {{"open", sessions.count()}}},
      {"gpuMemoryBytes", renderThread.gpuMemoryBytes()},
      {"validation",
       {{"enabled", config.validation}, {"messages", renderThread.validationMessages()}}},
      {"scene",
       {{"lights", scene.lights},
        {"instances", scene.instances},
        {"materials", scene.materials},
        {"meshes", scene.meshes}}},
      {"targets", targets},
      {"techniques", techniques},
      {"defaultTechnique", render::techniqueName(config.technique)},
  };
  res.set_content(info.dump(2, ' ', false, nlohmann::json::error_handler_t::replace),
                  std::string(protocol::kJsonContentType));
}

HttpServer::HttpServer(const HttpConfig& config, render::RenderQueue& renderThread,
                       const scene::Scene& scene)
    : state_(std::make_unique<State>(config, renderThread)) {
  State& s = *state_;
  s.api.connectionCounts = [&s] { return s.server.counts(); };
  s.frames.builtinLighting.takeLightingFrom(scene);
  s.frames.builtinDefaults = FrameDefaults{scene.camera, scene.bounds(), config.maxResolution,
                                          config.technique};
  s.scene = SceneSummary{scene.lights.size(), scene.instances.size(), scene.materials.size(),
                         scene.meshes.size()};
  if (config.nodeId) s.sessions.setNode(*config.nodeId);
  if (config.state != nullptr) {
    // Lease owner: the node's number, else one no node id (0-255) can be (several servers
    // sharing a store without --node-id still fence each other).
    const uint32_t owner = config.nodeId ? *config.nodeId : 256 + uint32_t(::getpid());
    s.api.stateNode = owner;
    s.sync = std::make_unique<SessionSync>(s.sessions, s.api, *config.state, owner,
                                           config.leaseTime, config.stateRetention);
    s.frames.metrics.setExtraSeries([&s] { return s.sync->exposition(""); });
  }

  httplib::Server& server = s.server;
  // The route table refuses bodies over each route's own limit from Content-Length; this bounds
  // what httplib reads of a body sent without one.
  server.set_payload_max_length(
      std::max(config.api.limits.maxUploadBytes, config.api.limits.maxBodyBytes));
  server.set_write_timeout(kWriteTimeoutSeconds, 0);
  // httplib writes a response's headers and body as two writes. With Nagle's algorithm on, the
  // body waits for the ACK of the headers, which a kept-alive client delays by up to 40 ms (its
  // delayed ACK): every request after a connection's first took 40 ms longer.
  server.set_tcp_nodelay(true);
  // httplib's default sets SO_REUSEPORT, which lets a second server bind the same port and take
  // a share of its connections. SO_REUSEADDR alone still allows a restart while old connections
  // sit in TIME_WAIT, but makes a port in use a start-up error.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });

  // Unknown paths, wrong methods (405 with Allow), preflights and oversized bodies are answered
  // before routing and before the body is read.
  server.set_pre_routing_handler([&s](const httplib::Request& req, httplib::Response& res) {
    tTrace = {std::chrono::steady_clock::now(), true};
    return s.routes.answerBeforeRouting(req, res) ? httplib::Server::HandlerResponse::Handled
                                                  : httplib::Server::HandlerResponse::Unhandled;
  });

  // httplib calls this for every status >= 400, including our own problem responses; only
  // statuses httplib produced itself (malformed requests, oversize bodies) arrive without a body.
  server.set_error_handler(
      httplib::Server::HandlerWithResponse([&s](const httplib::Request& req,
                                                httplib::Response& res) {
        if (!res.body.empty() || res.status == 204) {
          return httplib::Server::HandlerResponse::Unhandled;
        }
        sendProblem(res, problemForStatus(res.status, req, s.api.config.limits));
        return httplib::Server::HandlerResponse::Handled;
      }));

  server.set_exception_handler(
      [](const httplib::Request& req, httplib::Response& res, std::exception_ptr thrown) {
        std::string what = "unknown exception";
        try {
          std::rethrow_exception(thrown);
        } catch (const StoreUnavailable& e) {
          // The session store went away (a database restarting): this request waits for it,
          // the server serves everyone else.
          Problem problem = serverBusy(std::string("The session store cannot be reached: ") +
                                       e.what() + ". Retry shortly.");
          problem.retryAfterSeconds = 1;
          sendProblem(res, problem);
          return;
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        std::fprintf(stderr, "myriad-server: %s %s failed: %s\n", req.method.c_str(),
                     req.path.c_str(), what.c_str());
        sendProblem(res, internalError("The server failed while handling " +
                                       quoteClientText(req.path) + ": " + what));
      });

  // Every response passes here before it is written, whether a handler, the route table or
  // httplib itself produced it: counted under its route's template.
  // With a state store, a successful edit (any method but GET, HEAD, OPTIONS) reaches the store
  // here, before its response is written, or the response says it did not (SessionSync::
  // confirmEdit): a server killed after answering loses nothing it answered.
  const std::string nodeName =
      config.nodeId ? std::to_string(*config.nodeId) : std::string();
  s.frames.metrics.setNodeLabel(nodeName);
  server.set_post_routing_handler([&s, nodeName](const httplib::Request& req,
                                                 httplib::Response& res) {
    if (s.sync) s.sync->confirmEdit(req, res);
    s.frames.metrics.countRequest(s.routes.routeOf(req.path, req.method), res.status);
    if (!nodeName.empty()) res.set_header(std::string(protocol::headers::kNode), nodeName);
    const std::string requestId(protocol::headers::kRequestId);
    const std::string given = req.get_header_value(requestId);
    res.set_header(requestId, acceptableRequestId(given) ? given : newRequestId());
    BoundedHttpServer::markClosing(res);
  });
  server.set_logger([&s, nodeName, json = config.jsonAccessLog](const httplib::Request& req,
                                                               const httplib::Response& res) {
    logRequest(req, res, s.routes, json, nodeName);
  });

  namespace r = protocol::routes;
  RouteOptions health;
  health.countsInFlight = false;  // a load balancer's probe must not get 429 under load
  s.routes.add(
      "GET", r::kHealth,
      [](const httplib::Request&, httplib::Response& res) {
        res.set_content(R"({"status":"ok"})", std::string(protocol::kJsonContentType));
      },
      health);
  s.routes.add(
      "GET", r::kReady,
      [&s](const httplib::Request&, httplib::Response& res) {
        if (s.stopRequested) throw ProblemError(serverBusy("draining: the server is shutting down."));
        const size_t open = s.sessions.count();
        if (open >= s.sessions.maxSessions()) {
          throw ProblemError(serverBusy("full: " + std::to_string(open) + " of " +
                                        std::to_string(s.sessions.maxSessions()) + " sessions."));
        }
        res.set_content(R"({"status":"ok"})", std::string(protocol::kJsonContentType));
      },
      health);
  s.routes.add("GET", r::kInfo,
               [&s](const httplib::Request&, httplib::Response& res) { s.handleInfo(res); });
  s.routes.add("GET", r::kOpenApi, [&s](const httplib::Request&, httplib::Response& res) {
    res.set_content(s.openApi, std::string(protocol::kJsonContentType));
  });
  addSessionApi(s.routes, s.api);
  addFrameRoutes(s.routes, s.api, s.frames);
}

HttpServer::~HttpServer() = default;

uint16_t HttpServer::bind() {
  // GET /v1/openapi.json is the protocol's table of operations; a server that answers other
  // routes than it lists would publish a wrong document. Reported here, with the other reasons
  // not to start.
  if (std::string mismatch = routeTableMismatch(state_->routes.registered()); !mismatch.empty()) {
    throw std::runtime_error("the route table disagrees with the protocol: " + mismatch + ".");
  }
  const HttpConfig& config = state_->config;
  errno = 0;
  int port = -1;
  if (config.port == 0) {
    port = state_->server.bind_to_any_port(config.host);
  } else if (state_->server.bind_to_port(config.host, config.port)) {
    port = config.port;
  }
  if (port <= 0) {
    // httplib reports only failure; errno still holds bind()'s reason when that was the step.
    std::string reason = errno != 0 ? std::strerror(errno) : "the address is not valid here";
    throw std::runtime_error("cannot listen on " + config.host + ":" + std::to_string(config.port) +
                             " (" + reason + ").");
  }
  state_->server.widenBacklog();
  return static_cast<uint16_t>(port);
}

bool HttpServer::serve() {
  state_->serveEntered = true;
  bool stoppedCleanly = state_->stopRequested || state_->server.listen_after_bind();
  state_->serveFinished = true;
  return stoppedCleanly;
}

void HttpServer::stop() {
  State& s = *state_;
  s.stopRequested = true;
  // serve() checks stopRequested after announcing itself, and this checks serveEntered after
  // setting stopRequested (both sequentially consistent), so at least one side sees the other.
  // Streams wait on their session; closing every session ends them, so shutdown does not wait
  // on a client that never disconnects. The registry refuses streams that arrive after this.
  s.frames.streams.shutdown();
  // What changed since the last write goes to the state directory before the sessions close.
  if (s.sync) s.sync->flush();
  s.sessions.closeAll();
  if (!s.serveEntered) return;
  // httplib's stop() does nothing until listen has marked itself running; wait for that (or for
  // serve() to have given up) so a signal that arrives just after start-up is not lost.
  while (!s.server.is_running() && !s.serveFinished) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  s.server.stop();
}

}  // namespace myriad::service
