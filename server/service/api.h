// What the route files share: the server's limits and configuration, the render thread, the
// sessions, the model library, and a route table that answers 404, 405 (with Allow), 413 on
// oversize bodies and 429 on too many requests in flight before any handler runs. Handlers throw
// ProblemError for a client mistake; the table's wrapper turns it into a problem response.
#pragma once

#include <httplib.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/types.h"
#include "render/frame.h"
#include "service/http_connections.h"
#include "service/memory_budget.h"
#include "service/problem.h"
#include "service/session.h"

namespace myriad::loader {
class ModelLibrary;
}
namespace myriad::render {
class RenderQueue;
}

namespace myriad::service {

// Every limit /v1/info lists under "limits", with the same names.
struct ApiLimits {
  uint32_t maxResolution = 4096;
  uint32_t maxQueuedFrames = 4;
  uint32_t maxSessions = 16;
  uint32_t maxLightsPerSession = 1000000;
  uint32_t maxObjectsPerSession = 100000;
  uint64_t maxUploadBytes = 64ull << 20;
  uint64_t maxBodyBytes = 1ull << 20;
  uint32_t maxStreams = 8;
  uint32_t maxStreamsPerSession = 4;  // one session's share of maxStreams (stream_registry.h)
  uint32_t maxRequestsInFlight = 64;
  uint32_t sessionIdleSeconds = 600;
  uint64_t maxMemoryBytes = 0;  // --max-memory (memory_budget.h); 0 = none
  uint32_t maxFrameSeconds = 0;  // --max-frame-seconds: a frame's GPU work past it is 413; 0 = none

  nlohmann::json toJson() const;
};

struct ApiConfig {
  ApiLimits limits;
  std::optional<std::string> apiKey;     // POST /v1/sessions needs "Bearer <apiKey>" when set
  std::vector<std::string> corsOrigins;  // "*" allowed; empty = no CORS headers
  render::Technique defaultTechnique = render::Technique::Clustered;
  bool validation = false;
  // "builtin:default": the built-in scene with this many generated lights from this seed
  // (--lights, --seed).
  uint32_t builtinLights = 256;
  uint64_t builtinSeed = 1;
  // Session frames' pixels are encoded where the GPU put them (render::FrameSettings::
  // borrowPixels) rather than copied out on the render thread (--copy-frames turns it off).
  bool borrowPixels = true;
  // JPEG frames are converted to YCbCr 4:2:0 on the GPU (--rgba-jpeg turns it off).
  bool yuvJpeg = true;
};

struct ApiContext {
  ApiConfig config;
  render::RenderQueue& renderThread;  // the render thread, seen through its queue
  SessionManager& sessions;
  loader::ModelLibrary* models = nullptr;  // null without --models
  StateStore* state = nullptr;             // null without --state-dir / --state-store
  MemoryBudget* memory = nullptr;          // --max-memory; null in unit tests (no limit)
  // What the connection layer has done (GET /metrics); empty in unit tests.
  std::function<ConnectionCounts()> connectionCounts;
  // The lease owner this server writes to `state` as (session_sync.h).
  uint32_t stateNode = 0;
};

// Reserves `bytes` of the memory budget for `what` (memory_budget.h): a held reservation, or the
// 413/503 problem thrown. Without a budget, an empty reservation.
MemoryBudget::Reservation reserveMemory(const ApiContext& context, uint64_t bytes,
                                        std::string_view what);

// With --state-dir: the session `id` from its state file, open again with `token` (checked
// against the stored hash: 403 otherwise); null when there is no such file, or when the file is
// refused (reported on stderr, naming the file and why): not a record, a snapshot the API would
// refuse, a model or environment that no longer loads. Loads its model and environment as an
// upload or creation would; a busy loader (503) or no room for a session (429) is thrown.
SessionPtr restoreStoredSession(ApiContext& context, std::string_view id, const std::string& token);

// A new session holding `snapshot` (its model built-in or from the library), made as
// POST /v1/sessions {"snapshot": ...} makes it (batch rendering uses it). Throws ProblemError.
SessionPtr createSessionFromSnapshot(ApiContext& context, const protocol::Snapshot& snapshot);

// Sends `problem` as application/problem+json, with Retry-After when it says so.
void sendProblem(httplib::Response& res, const Problem& problem);

// Sends `body` as application/json (pretty enough for curl users, without escaping UTF-8).
void sendJson(httplib::Response& res, const nlohmann::json& body, int status = 200);

struct RouteOptions {
  // Counted against maxRequestsInFlight while the handler runs (429 beyond). Health is not.
  bool countsInFlight = true;
  // Largest body accepted (413 limit maxBodyBytes beyond); 0 = the context's maxBodyBytes.
  uint64_t maxBodyBytes = 0;
  // The limit named in a 413 for this route's body.
  std::string bodyLimitName = "maxBodyBytes";
};

struct RouteKey {
  std::string method;
  std::string routeTemplate;
};

// "" when `registered` is exactly the operations of protocol/operations.cpp (each method and
// template once), else a sentence naming what is missing from the server and what it has beyond
// the protocol. GET /v1/openapi.json is built from that table, so the server refuses to start on
// a difference (HttpServer::bind).
std::string routeTableMismatch(const std::vector<RouteKey>& registered);

class Routes {
 public:
  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;

  Routes(httplib::Server& server, ApiContext& context);

  // Registers `handler` for `method` ("GET", "POST", "PUT", "PATCH", "DELETE") on
  // `routeTemplate`, a path whose segments are literal or "{name}" (one non-empty segment without
  // '/'): "/v1/sessions/{id}/lights/{lid}". The {name} segments land in req.matches[1..] in order.
  // GET also answers HEAD. The handler may throw ProblemError. The template is the route's label
  // in metrics; pass a protocol::routes constant.
  void add(std::string_view method, std::string_view routeTemplate, Handler handler,
           RouteOptions options = {});
  // The same for the operation of protocol/operations.cpp with this operationId: its method and
  // template come from the table, so a route only the table names needs no routes:: constant.
  // Throws std::logic_error for an id the table lacks (a bug, found at start-up).
  void add(std::string_view operationId, Handler handler, RouteOptions options = {});

  // For the pre-routing handler: answers 404 (no route has this path), 405 with Allow, OPTIONS
  // preflights (with CORS) and 413 on a Content-Length over the route's limit. True when it
  // answered and routing must stop.
  bool answerBeforeRouting(const httplib::Request& req, httplib::Response& res) const;

  // Sets Access-Control-Allow-Origin when the request's Origin is allowed.
  void addCorsHeaders(const httplib::Request& req, httplib::Response& res) const;

  // The template of the route `path` belongs to, for metrics ("unmatched" when none).
  std::string routeOf(const std::string& path, const std::string& method = "GET") const;

  // Every (method, template) added, in order; the HEAD that comes with each GET is not listed.
  std::vector<RouteKey> registered() const;

  uint32_t requestsInFlight() const { return inFlight_.load(); }

 private:
  struct Entry {
    std::string routeTemplate;
    std::regex regex;
    std::vector<std::string> methods;
    RouteOptions options;
  };
  const Entry* match(const std::string& path, const std::string& method) const;
  static std::string allowHeader(const Entry& entry);
  // The request with its body read through `reader`, counted as it arrives: a ProblemError (413
  // naming the route's limit, Connection: close) as soon as it exceeds options.maxBodyBytes,
  // without reading on; 400 for a body that cannot be read (bad chunking, early end).
  static std::shared_ptr<httplib::Request> readBounded(const httplib::Request& req,
                                                       httplib::Response& res,
                                                       const httplib::ContentReader& reader,
                                                       const RouteOptions& options);

  httplib::Server& server_;
  ApiContext& context_;
  std::vector<Entry> entries_;
  mutable std::atomic<uint32_t> inFlight_{0};
};

// A handler written as a function of the context, bound to `context` for Routes::add.
using ContextHandler = void (*)(ApiContext&, const httplib::Request&, httplib::Response&);
inline Routes::Handler bindContext(ApiContext& context, ContextHandler handler) {
  return [&context, handler](const httplib::Request& req, httplib::Response& res) {
    handler(context, req, res);
  };
}

// POST/GET/DELETE sessions, PUT model, GET /v1/models (api_sessions.cpp).
void addSessionRoutes(Routes& routes, ApiContext& context);
// Camera, settings and materials of a session (api_scene.cpp).
void addSceneRoutes(Routes& routes, ApiContext& context);
// The environment image "library:NAME.hdr" names, decoded in the loader child (api_scene.cpp).
// Throws ProblemError 404 (not in the library), 422 environment-rejected, 503 (loader busy).
std::shared_ptr<const scene::EnvironmentImage> loadLibraryEnvironment(const ApiContext& context,
                                                                      const std::string& source);
// A session's lights (api_lights.cpp).
void addLightRoutes(Routes& routes, ApiContext& context);
// A session's assets and objects (api_objects.cpp).
void addObjectRoutes(Routes& routes, ApiContext& context);
// All four; FRAMES registers frame, stream and stats routes next to them.
inline void addSessionApi(Routes& routes, ApiContext& context) {
  addSessionRoutes(routes, context);
  addSceneRoutes(routes, context);
  addLightRoutes(routes, context);
  addObjectRoutes(routes, context);
}

// A model as PUT .../model and POST .../assets take it: the file itself
// (application/octet-stream, ?filename=), a zip (?entry=), several files (multipart/form-data,
// ?entry=) or JSON {"source": "builtin:default" | "library:NAME"}, loaded in the loader child.
struct LoadedModel {
  std::shared_ptr<scene::Scene> scene;
  std::string source;   // builtin:default, library:NAME, upload:FILE
  std::string assetId;  // assetIdOf(the bytes, or the source's name)
  uint64_t bytes = 0;   // of the upload (0: not an upload)
  std::optional<StoredUpload> stored;  // with --state-dir: the bytes kept for a restore
};
// Throws ProblemError: 400 (a bad ?filename= or ?entry=), 404 (not in the library), 413 (a JSON
// body over maxBodyBytes), 415, 422 model-rejected, 503 (the loader busy).
LoadedModel loadModelRequest(ApiContext& context, const httplib::Request& req);

// Credentials of a request: the Authorization header and, for routes that allow it, ?token=.
Credentials credentialsOf(const httplib::Request& req);

// The request's body as JSON that conforms to protocol/schemas/<schemaName>.schema.json. Throws
// ProblemError: 415 when Content-Type is not application/json, 400 invalid-body (with the pointer)
// when it is not JSON or breaks the schema. A request without a body is read as `emptyBody` when
// given (POST /v1/sessions takes "{}"), else refused.
nlohmann::json jsonBody(const httplib::Request& req, std::string_view schemaName,
                        std::optional<std::string_view> emptyBody = std::nullopt);
// The same against the schema the route's operation names for its JSON body (the table's, so the
// handler does not repeat it); no body is "{}" when the operation's body is optional. Throws
// std::logic_error on an operation without a JSON body.
nlohmann::json jsonBody(const httplib::Request& req);

// The session the route table authorized for the request being served: Routes::add applies each
// operation's access (protocol/operations.cpp) and query parameters before its handler runs, so
// handlers neither authorize nor list parameters themselves. Throws std::logic_error on a route
// whose operation takes no session token (a bug: the table and the handler disagree).
SessionPtr requestSession();
// Query parameter `name` as an integer in [min, max], `fallback` when absent; 400
// invalid-parameter naming it otherwise.
uint64_t unsignedParameter(const httplib::Request& req, const std::string& name, uint64_t fallback,
                           uint64_t min, uint64_t max);

// A session's mutex as a handler holds it (lockOpen). While held, what the request saw is the
// session at `version`; on release it answers that version as the response's ETag, and a later
// lockOpen of the same request checks nothing else changed the session in between.
class SessionLock {
 public:
  explicit SessionLock(Session& session);
  ~SessionLock();
  SessionLock(SessionLock&& other) noexcept;
  SessionLock(const SessionLock&) = delete;
  SessionLock& operator=(const SessionLock&) = delete;
  SessionLock& operator=(SessionLock&&) = delete;

 private:
  Session* session_;
  std::unique_lock<std::mutex> lock_;
};

// Locks an open session; throws ProblemError 404 when it was closed (deleted or expired) since it
// was authorized. Every handler that reads or edits session state takes this lock.
// Optimistic concurrency: for an edit (any method but GET and HEAD) carrying If-Match, throws
// ProblemError 412 precondition-failed unless the session is still at a version the header names
// (its ETag, or `*`) - checked under the lock, so the edit that follows applies to exactly that
// version. Without If-Match an edit applies to the latest version.
SessionLock lockOpen(Session& session);

// The session's version as an entity tag (quoted): the version and this server process's
// instance, so a tag from before a restart or from another node never matches a restored copy.
std::string entityTag(const Session& session);

// With --api-key: throws the 401 problem unless the request carries the key as a bearer token.
void requireApiKey(const ApiContext& context, const httplib::Request& req);

// The authorized session named by the route's first {id} segment (req.matches[1]).
// Throws ProblemError (401/403/404).
SessionPtr authorizeSession(const ApiContext& context, const httplib::Request& req,
                            bool allowQueryToken = false);

}  // namespace myriad::service
