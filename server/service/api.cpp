#include "service/api.h"

#include <charconv>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <random>
#include <set>
#include <utility>

#include "protocol/constants.h"
#include "protocol/operations.h"
#include "protocol/validate.h"
#include "service/connection.h"
#include "service/stream.h"

namespace myriad::service {
namespace {

// A glTF folder with its buffers and textures is tens of files; thousands of parts is not an upload.
constexpr size_t kMaxMultipartParts = 4096;
// What one part costs to hold beyond its bytes (its map node and strings), counted against the limit.
constexpr uint64_t kPartOverheadBytes = 256;

// What a browser may send and read across origins: the token, JSON bodies, and the headers that
// carry timings and frame metadata.
const std::string kCorsAllowHeaders =
    std::string(protocol::headers::kAuthorization) + ", Content-Type, " +
    std::string(protocol::headers::kInteraction) + ", " + std::string(protocol::headers::kIfMatch);
const std::string kCorsExposeHeaders = [] {
  namespace h = protocol::headers;
  std::string list;
  for (std::string_view name : {h::kServerTiming, h::kRetryAfter, h::kTechnique, h::kChannels,
                                h::kWidth, h::kHeight, h::kTarget, h::kFrameSequence, h::kIntrinsics,
                                h::kPose, h::kDepth, h::kDtype, h::kSpace, h::kETag,
                                h::kRequestId}) {
    list += (list.empty() ? "" : ", ") + std::string(name);
  }
  return list;
}();
constexpr const char* kCorsMaxAgeSeconds = "600";

// The request a worker thread serves while its handler runs (Routes::add's `serve` sets it):
// what lockOpen needs to honour If-Match and to answer the ETag, without every handler passing
// the request down. httplib runs a handler on one thread, start to end; a stream's content
// provider runs after it, with no scope.
struct RequestScope {
  httplib::Response& res;
  bool edits = false;  // any method but GET and HEAD
  std::optional<std::string> ifMatch;  // the header as sent
  // The session version this request last held the lock at (SessionLock's release): a later
  // lockOpen of the same request refuses a session someone else changed in between.
  std::optional<uint64_t> seenVersion;
  // The session the operation's access authorized (requestSession()); null on other routes.
  SessionPtr session;
  // The route's entry of protocol/operations.cpp (jsonBody(req) reads its body schema).
  const protocol::Operation* operation = nullptr;
};
thread_local RequestScope* tRequest = nullptr;

// Throws ProblemError 400 unknown-parameter for a query parameter not in `allowed` (the
// operation's, from protocol/operations.cpp), and 400 invalid-parameter for one given twice.
void checkQuery(const httplib::Request& req, const std::vector<std::string>& allowed) {
  std::set<std::string> seen;
  for (const auto& [name, value] : req.params) {
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      std::string known;
      for (std::string_view a : allowed) known += (known.empty() ? "" : ", ") + std::string(a);
      throw ProblemError(unknownParameter(
          name, "This route takes no query parameter " + quoteClientText(name) +
                    (known.empty() ? std::string(" (it takes none).")
                                   : "; it takes: " + known + ".")));
    }
    if (!seen.insert(name).second) {
      throw ProblemError(
          invalidParameter(name, "The parameter " + quoteClientText(name) + " is given twice."));
    }
  }
}

// This process's part of every entity tag (entityTag): random, so that a session restored by
// another process (a restart, another node) never matches a tag its former copy gave out.
const std::string kInstanceTag = [] {
  std::random_device random;
  char text[9];
  std::snprintf(text, sizeof text, "%08x", static_cast<unsigned>(random()));
  return std::string(text);
}();

// Does If-Match's value (`*`, or a comma-separated list of entity tags, RFC 9110 13.1.1) name
// `tag`? Weak tags (W/"...") never match: If-Match compares strongly.
bool ifMatchNames(std::string_view header, std::string_view tag) {
  size_t start = 0;
  while (start <= header.size()) {
    size_t end = header.find(',', start);
    if (end == std::string_view::npos) end = header.size();
    std::string_view item = header.substr(start, end - start);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    if (item == "*" || item == tag) return true;
    start = end + 1;
  }
  return false;
}

// One ETag header, the latest (httplib's set_header adds another).
void setEntityTag(httplib::Response& res, const std::string& tag) {
  const std::string name(protocol::headers::kETag);
  res.headers.erase(name);
  res.set_header(name, tag);
}

// 412 for an edit whose If-Match names not `session` as it is now; with the lock held.
void checkPrecondition(const RequestScope& scope, const Session& session) {
  if (!scope.edits || !scope.ifMatch) return;
  const std::string tag = entityTag(session);
  const bool changedMeanwhile = scope.seenVersion && *scope.seenVersion != session.version;
  if (!changedMeanwhile && (scope.seenVersion || ifMatchNames(*scope.ifMatch, tag))) return;
  setEntityTag(scope.res, tag);
  throw ProblemError(preconditionFailed(
      "The session is no longer at the version this edit's If-Match names (" +
      scope.ifMatch->substr(0, 200) + ")" +
      (changedMeanwhile ? ": another request changed it while this one ran" : "") +
      "; it is now at ETag " + tag + ". Read it again (GET) and retry with that ETag, or send "
      "the edit without If-Match to apply it to the latest version."));
}

std::string lowercase(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

// "application/json; charset=utf-8" -> "application/json".
std::string mediaType(std::string_view contentType) {
  std::string_view type = contentType.substr(0, contentType.find(';'));
  while (!type.empty() && type.back() == ' ') type.remove_suffix(1);
  while (!type.empty() && type.front() == ' ') type.remove_prefix(1);
  return lowercase(type);
}

// What a body costs in memory at its peak (memory_budget.h): its announced length (a chunked
// one: the route's limit, all it may reach) times what a byte becomes: a JSON document and the
// values made from it, or an upload's copies and loaded scene.
uint64_t bodyMemoryCost(const httplib::Request& req, const RouteOptions& options) {
  uint64_t bytes = options.maxBodyBytes;
  if (req.has_header("Content-Length")) {
    try {
      bytes = std::min<uint64_t>(bytes, std::stoull(req.get_header_value("Content-Length")));
    } catch (const std::exception&) {
    }
  }
  const bool json = mediaType(req.get_header_value("Content-Type")) == protocol::kJsonContentType;
  return bytes * (json ? memory_cost::kJsonBodyFactor : memory_cost::kUploadFactor);
}

// "/v1/sessions/{id}/lights/{lid}" -> "/v1/sessions/([^/]+)/lights/([^/]+)".
std::string templateToRegex(std::string_view routeTemplate) {
  std::string regex;
  for (size_t i = 0; i < routeTemplate.size(); ++i) {
    char c = routeTemplate[i];
    if (c == '{') {
      size_t close = routeTemplate.find('}', i);
      regex += "([^/]+)";
      i = close;
      continue;
    }
    if (std::isalnum(static_cast<unsigned char>(c)) || c == '/' || c == '-' || c == '_') {
      regex.push_back(c);
    } else {
      regex.push_back('\\');
      regex.push_back(c);
    }
  }
  return regex;
}

std::string joinMethods(const std::vector<std::string>& methods) {
  std::string text;
  for (const std::string& m : methods) {
    if (!text.empty()) text += ", ";
    text += m;
  }
  return text;
}

}  // namespace

nlohmann::json ApiLimits::toJson() const {
  return {
      {"maxResolution", maxResolution},
      {"maxQueuedFrames", maxQueuedFrames},
      {"maxSessions", maxSessions},
      {"maxLightsPerSession", maxLightsPerSession},
      {"maxObjectsPerSession", maxObjectsPerSession},
      {"maxUploadBytes", maxUploadBytes},
      {"maxBodyBytes", maxBodyBytes},
      {"maxStreams", maxStreams},
      {std::string(protocol::limits::kMaxStreamsPerSession), maxStreamsPerSession},
      {"maxRequestsInFlight", maxRequestsInFlight},
      {"sessionIdleSeconds", sessionIdleSeconds},
      {std::string(protocol::limits::kMaxMemoryBytes), maxMemoryBytes},
      {std::string(protocol::limits::kMaxFrameSeconds), maxFrameSeconds},
      {std::string(protocol::limits::kMaxEventStreamsPerSession), kMaxEventStreamsPerSession},
      {std::string(protocol::limits::kMaxEventStreams), kMaxEventStreams},
      {std::string(protocol::limits::kMaxFrameTargets), protocol::query::kMaxFrameTargets},
  };
}

void sendProblem(httplib::Response& res, const Problem& problem) {
  res.status = problem.status;
  if (problem.retryAfterSeconds) {
    res.set_header(std::string(protocol::headers::kRetryAfter),
                   std::to_string(*problem.retryAfterSeconds));
  }
  res.set_content(toBody(problem), std::string(protocol::kProblemContentType));
}

void sendJson(httplib::Response& res, const nlohmann::json& body, int status) {
  res.status = status;
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                  std::string(protocol::kJsonContentType));
}

Routes::Routes(httplib::Server& server, ApiContext& context)
    : server_(server), context_(context) {}

void Routes::add(std::string_view operationId, Handler handler, RouteOptions options) {
  for (const protocol::Operation& operation : protocol::operations()) {
    if (operation.id == operationId) {
      add(operation.method, operation.route, std::move(handler), options);
      return;
    }
  }
  throw std::logic_error("Routes::add: protocol/operations.cpp has no operation " +
                         std::string(operationId));
}

void Routes::add(std::string_view method, std::string_view routeTemplate, Handler handler,
                 RouteOptions options) {
  if (options.maxBodyBytes == 0) options.maxBodyBytes = context_.config.limits.maxBodyBytes;
  auto existing = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) {
    return e.routeTemplate == routeTemplate;
  });
  if (existing == entries_.end()) {
    entries_.push_back(Entry{std::string(routeTemplate),
                             std::regex(templateToRegex(routeTemplate)), {}, options});
    existing = entries_.end() - 1;
  }
  existing->methods.emplace_back(method);
  if (method == "GET") existing->methods.emplace_back("HEAD");
  // The body limit is per template; a method with a larger one (PUT model) raises it.
  existing->options.maxBodyBytes = std::max(existing->options.maxBodyBytes, options.maxBodyBytes);

  // What protocol/operations.cpp says of the route, applied here for every handler: who may call
  // it (its access) and which query parameters it takes. A route the table lacks is not checked
  // here: the server refuses to start on it (routeTableMismatch, HttpServer::bind).
  const protocol::Operation* operation = protocol::findOperation(method, routeTemplate);
  const protocol::Access access = operation ? operation->access : protocol::Access::Public;
  std::vector<std::string> queryNames;
  if (operation) {
    for (std::string_view name : protocol::queryParameterNames(*operation)) {
      queryNames.emplace_back(name);
    }
  }

  // Everything but reading the body: the in-flight limit, the operation's access and query
  // parameters, the form refusal, problems. Called with the body already read (and bounded) by
  // the caller.
  auto serve = [this, handler = std::move(handler), options, access, operation,
                checksQuery = operation != nullptr && !operation->anyQuery, queryNames = std::move(queryNames)](
                   const httplib::Request& req, httplib::Response& res, const auto& readBody) {
    struct InFlight {
      std::atomic<uint32_t>* counter = nullptr;
      ~InFlight() {
        if (counter != nullptr) counter->fetch_sub(1);
      }
    } inFlight;
    if (options.countsInFlight) {
      inFlight.counter = &inFlight_;
      const uint32_t limit = context_.config.limits.maxRequestsInFlight;
      if (inFlight_.fetch_add(1) + 1 > limit) {
        // Before the body is read: a refused request costs no memory for its body.
        res.set_header("Connection", "close");
        sendProblem(res, limitExceeded(429, "maxRequestsInFlight",
                                       "The server is already handling " + std::to_string(limit) +
                                           " requests, its limit; retry shortly."));
        return;
      }
    }
    RequestScope scope{.res = res,
                       .edits = req.method != "GET" && req.method != "HEAD",
                       .ifMatch = std::nullopt,
                       .seenVersion = std::nullopt,
                       .operation = operation};
    const std::string ifMatch(protocol::headers::kIfMatch);
    if (req.has_header(ifMatch)) scope.ifMatch = req.get_header_value(ifMatch);
    struct Scoped {
      explicit Scoped(RequestScope* s) { tRequest = s; }
      ~Scoped() { tRequest = nullptr; }
    } scoped(&scope);
    try {
      // Before a byte of the body is read: refusing an unauthenticated upload costs neither
      // memory nor time (the connection closes with the body unread).
      switch (access) {
        case protocol::Access::Public:
          break;
        case protocol::Access::ApiKeyWhenSet:
          requireApiKey(context_, req);
          break;
        case protocol::Access::Session:
        case protocol::Access::SessionOrQueryToken:
          scope.session = authorizeSession(context_, req,
                                           access == protocol::Access::SessionOrQueryToken);
          break;
      }
      if (checksQuery) checkQuery(req, queryNames);
      // A conditional edit of a session: refused before its body is read when already stale.
      // (The handler's lockOpen checks again, under the lock its edit holds.)
      if (scope.edits && scope.ifMatch && scope.session) {
        std::lock_guard lock(scope.session->mutex);
        checkPrecondition(scope, *scope.session);
      }
      const httplib::Request& withBody = readBody();
      // httplib reads a form body into req.params, where it would pass for a query string; no
      // route takes a form (curl -d sends one unless told the type).
      if (!withBody.body.empty() &&
          mediaType(req.get_header_value("Content-Type")) == "application/x-www-form-urlencoded") {
        throw ProblemError(unsupportedMediaType(
            "This route takes no form; send JSON with Content-Type: application/json (curl: "
            "--json or -H 'Content-Type: application/json')."));
      }
      handler(withBody, res);
    } catch (const ProblemError& e) {
      sendProblem(res, e.problem());
    }
  };

  const std::string regex = templateToRegex(routeTemplate);
  if (method == "GET" || method == "DELETE") {
    httplib::Server::Handler bodiless = [serve](const httplib::Request& req,
                                               httplib::Response& res) {
      serve(req, res, [&]() -> const httplib::Request& { return req; });
    };
    if (method == "GET") {
      server_.Get(regex, bodiless);
    } else {
      server_.Delete(regex, bodiless);
    }
    return;
  }
  // Bodies are read here, not by httplib, so that they are counted as they arrive and cut at the
  // route's limit: httplib 0.11 reads a chunked body (no Content-Length; the route table refuses
  // an oversized one before routing) whole into memory, however large.
  httplib::Server::HandlerWithContentReader reading =
      [this, serve, options](const httplib::Request& req, httplib::Response& res,
                             const httplib::ContentReader& reader) {
        std::shared_ptr<httplib::Request> withBody;
        MemoryBudget::Reservation memory;  // held until the handler has answered
        serve(req, res, [&]() -> const httplib::Request& {
          memory = reserveMemory(context_, bodyMemoryCost(req, options), "this request's body");
          withBody = readBounded(req, res, reader, options);
          return *withBody;
        });
      };
  if (method == "POST") {
    server_.Post(regex, reading);
  } else if (method == "PUT") {
    server_.Put(regex, reading);
  } else if (method == "PATCH") {
    server_.Patch(regex, reading);
  } else {
    throw std::invalid_argument("Routes::add: unsupported method " + std::string(method));
  }
}

std::shared_ptr<httplib::Request> Routes::readBounded(const httplib::Request& req,
                                                      httplib::Response& res,
                                                      const httplib::ContentReader& reader,
                                                      const RouteOptions& options) {
  // A copy of the request without its body (headers, query, path matches into req.path), to
  // which the body is added as it is read.
  auto withBody = std::make_shared<httplib::Request>(req);
  uint64_t received = 0;
  bool overLimit = false;
  bool tooManyParts = false;
  auto count = [&](size_t n) {
    received += n;
    if (received > options.maxBodyBytes) overLimit = true;
    return !overLimit;
  };
  bool complete = false;
  connection::setBodyLimit(options.maxBodyBytes);
  if (req.is_multipart_form_data()) {
    // As httplib's own reader does: each part's headers, then its content appended to it. A
    // part's headers count against the limit as well as its content (with what a part costs
    // to hold), so a body of millions of empty parts is cut like any other large body.
    httplib::MultipartFormDataMap::iterator current = withBody->files.end();
    size_t parts = 0;
    complete = reader(
        [&](const httplib::MultipartFormData& part) {
          if (++parts > kMaxMultipartParts) {
            tooManyParts = true;
            return false;
          }
          if (!count(kPartOverheadBytes + part.name.size() + part.filename.size() +
                     part.content_type.size())) {
            return false;
          }
          current = withBody->files.emplace(part.name, part);
          return true;
        },
        [&](const char* data, size_t n) {
          if (!count(n) || current == withBody->files.end()) return false;
          current->second.content.append(data, n);
          return true;
        });
  } else {
    complete = reader([&](const char* data, size_t n) {
      if (!count(n)) return false;
      withBody->body.append(data, n);
      return true;
    });
  }
  if (tooManyParts) {
    res.set_header("Connection", "close");
    throw ProblemError(limitExceeded(
        413, options.bodyLimitName,
        "The multipart body has more than " + std::to_string(kMaxMultipartParts) +
            " parts; the rest was not read."));
  }
  if (overLimit) {
    // What is still on its way is never read: the connection closes after this answer.
    res.set_header("Connection", "close");
    throw ProblemError(limitExceeded(
        413, options.bodyLimitName,
        "The request body exceeded this route's limit of " +
            std::to_string(options.maxBodyBytes) + " bytes after " + std::to_string(received) +
            " bytes had arrived; the rest was not read."));
  }
  if (!complete) {
    res.set_header("Connection", "close");
    throw ProblemError(invalidBody(
        "", req.is_multipart_form_data()
                ? "The multipart body could not be read: malformed, or the connection ended early."
                : "The request body could not be read: malformed chunked encoding, or the "
                  "connection ended early."));
  }
  return withBody;
}

const Routes::Entry* Routes::match(const std::string& path, const std::string& method) const {
  // "/lights/generate" also matches "/lights/{lid}": prefer the entry that serves the method.
  const Entry* first = nullptr;
  for (const Entry& entry : entries_) {
    if (!std::regex_match(path, entry.regex)) continue;
    if (std::find(entry.methods.begin(), entry.methods.end(), method) != entry.methods.end()) {
      return &entry;
    }
    if (first == nullptr) first = &entry;
  }
  return first;
}

std::string Routes::allowHeader(const Entry& entry) {
  std::vector<std::string> methods = entry.methods;
  methods.emplace_back("OPTIONS");
  return joinMethods(methods);
}

std::string Routes::routeOf(const std::string& path, const std::string& method) const {
  const Entry* entry = match(path, method);
  return entry != nullptr ? entry->routeTemplate : "unmatched";
}

std::vector<RouteKey> Routes::registered() const {
  std::vector<RouteKey> keys;
  for (const Entry& entry : entries_) {
    for (const std::string& method : entry.methods) {
      if (method != "HEAD") keys.push_back({method, entry.routeTemplate});
    }
  }
  return keys;
}

std::string routeTableMismatch(const std::vector<RouteKey>& registered) {
  std::set<std::pair<std::string, std::string>> server;
  std::string twice;
  for (const RouteKey& key : registered) {
    if (!server.emplace(key.method, key.routeTemplate).second) {
      twice += (twice.empty() ? "" : ", ") + key.method + " " + key.routeTemplate;
    }
  }
  std::set<std::pair<std::string, std::string>> table;
  for (const protocol::Operation& op : protocol::operations()) {
    table.emplace(std::string(op.method), std::string(op.route));
  }
  auto listOf = [](const auto& from, const auto& without) {
    std::string text;
    for (const auto& [method, route] : from) {
      if (without.count({method, route}) != 0) continue;
      text += (text.empty() ? "" : ", ") + method + " " + route;
    }
    return text;
  };
  const std::string missing = listOf(table, server);
  const std::string extra = listOf(server, table);
  std::string sentence;
  if (!missing.empty()) {
    sentence += "the server has no route for " + missing + " of protocol/operations.cpp";
  }
  if (!extra.empty()) {
    sentence += (sentence.empty() ? "" : "; ") + std::string("the server answers ") + extra +
                ", which protocol/operations.cpp does not list";
  }
  if (!twice.empty()) {
    sentence += (sentence.empty() ? "" : "; ") + std::string("registered twice: ") + twice;
  }
  return sentence;
}

void Routes::addCorsHeaders(const httplib::Request& req, httplib::Response& res) const {
  const std::vector<std::string>& origins = context_.config.corsOrigins;
  if (origins.empty()) return;
  const std::string origin = req.get_header_value("Origin");
  const bool any = std::find(origins.begin(), origins.end(), "*") != origins.end();
  if (any) {
    res.set_header("Access-Control-Allow-Origin", "*");
  } else if (!origin.empty() && std::find(origins.begin(), origins.end(), origin) != origins.end()) {
    res.set_header("Access-Control-Allow-Origin", origin);
    res.set_header("Vary", "Origin");
  } else {
    return;
  }
  res.set_header("Access-Control-Expose-Headers", kCorsExposeHeaders);
}

bool Routes::answerBeforeRouting(const httplib::Request& req, httplib::Response& res) const {
  addCorsHeaders(req, res);
  const Entry* entry = match(req.path, req.method);
  if (entry == nullptr) {
    sendProblem(res, notFound(req.path));
    return true;
  }
  if (req.method == "OPTIONS") {
    // A CORS preflight (or a client asking what the route supports).
    const std::string allow = allowHeader(*entry);
    res.status = 204;
    res.set_header(std::string(protocol::headers::kAllow), allow);
    if (res.has_header("Access-Control-Allow-Origin")) {
      res.set_header("Access-Control-Allow-Methods", allow);
      res.set_header("Access-Control-Allow-Headers", kCorsAllowHeaders);
      res.set_header("Access-Control-Max-Age", kCorsMaxAgeSeconds);
    }
    return true;
  }
  if (std::find(entry->methods.begin(), entry->methods.end(), req.method) ==
      entry->methods.end()) {
    const std::string allow = allowHeader(*entry);
    res.set_header(std::string(protocol::headers::kAllow), allow);
    sendProblem(res, methodNotAllowed(req.method, req.path, allow));
    return true;
  }
  // RFC 9112 section 6.3: a request with neither Content-Length nor Transfer-Encoding has an
  // empty body. httplib 0.11 would instead read until the connection's read timeout (5 s) and then
  // refuse the request, so `curl -X POST .../v1/sessions` with no body stalled. Saying so in the
  // headers before httplib reads the body gives the standard behaviour. httplib hands the
  // pre-routing handler a const view of its own, non-const Request, so the cast is sound.
  if ((req.method == "POST" || req.method == "PUT" || req.method == "PATCH") &&
      !req.has_header("Content-Length") && !req.has_header("Transfer-Encoding")) {
    const_cast<httplib::Request&>(req).headers.emplace("Content-Length", "0");
  }
  // Refused before the body is read, so an oversized upload costs no memory.
  if (req.has_header("Content-Length")) {
    const std::string length = req.get_header_value("Content-Length");
    uint64_t bytes = 0;
    try {
      bytes = std::stoull(length);
    } catch (...) {
      bytes = UINT64_MAX;
    }
    if (bytes > entry->options.maxBodyBytes) {
      const std::string& limitName = entry->options.bodyLimitName;
      const uint64_t limit = entry->options.maxBodyBytes;
      res.set_header("Connection", "close");
      sendProblem(res, limitExceeded(413, limitName,
                                     "The request body has " + length +
                                         " bytes; the limit for this route is " +
                                         std::to_string(limit) + "."));
      return true;
    }
  }
  return false;
}

nlohmann::json jsonBody(const httplib::Request& req, std::string_view schemaName,
                        std::optional<std::string_view> emptyBody) {
  std::string_view text = req.body;
  if (text.empty() && emptyBody) {
    text = *emptyBody;
  } else {
    const std::string type = mediaType(req.get_header_value("Content-Type"));
    if (type != protocol::kJsonContentType) {
      throw ProblemError(unsupportedMediaType(
          "This route takes Content-Type: application/json, not " +
          quoteClientText(type.empty() ? std::string("none") : type) + "."));
    }
  }
  protocol::ParsedBody parsed = protocol::parseBody(schemaName, text);
  if (!parsed.ok()) throw ProblemError(invalidBody(parsed.error->pointer, parsed.error->message));
  return std::move(parsed.json);
}

nlohmann::json jsonBody(const httplib::Request& req) {
  const protocol::Operation* operation = tRequest != nullptr ? tRequest->operation : nullptr;
  if (operation != nullptr) {
    for (const protocol::Content& content : operation->body) {
      if (content.mediaType == protocol::kJsonContentType && !content.schema.empty()) {
        // An operation whose body is optional reads no body as an empty object.
        return jsonBody(req, content.schema,
                        operation->bodyRequired ? std::nullopt
                                                : std::optional<std::string_view>("{}"));
      }
    }
  }
  throw std::logic_error("jsonBody(req) on a route whose operation takes no JSON body");
}

SessionPtr requestSession() {
  if (tRequest == nullptr || !tRequest->session) {
    throw std::logic_error("requestSession() on a route whose operation takes no session token");
  }
  return tRequest->session;
}

Credentials credentialsOf(const httplib::Request& req) {
  Credentials credentials;
  const std::string authorization(protocol::headers::kAuthorization);
  const std::string token(protocol::query::kToken);
  if (req.has_header(authorization)) credentials.authorization = req.get_header_value(authorization);
  if (req.has_param(token)) credentials.queryToken = req.get_param_value(token);
  return credentials;
}

SessionLock::SessionLock(Session& session) : session_(&session), lock_(session.mutex) {}

SessionLock::SessionLock(SessionLock&& other) noexcept
    : session_(std::exchange(other.session_, nullptr)), lock_(std::move(other.lock_)) {}

SessionLock::~SessionLock() {
  if (session_ == nullptr || !lock_.owns_lock() || tRequest == nullptr) return;
  tRequest->seenVersion = session_->version;
  setEntityTag(tRequest->res, entityTag(*session_));
}

SessionLock lockOpen(Session& session) {
  SessionLock lock(session);
  if (session.closed) {
    throw ProblemError(notFoundDetail("The session " + quoteClientText(session.id) +
                                      " was deleted or expired during this request."));
  }
  if (tRequest != nullptr) checkPrecondition(*tRequest, session);
  return lock;
}

std::string entityTag(const Session& session) {
  // Appended piece by piece (GCC 12 warns falsely, -Wrestrict, on "\"" + std::string).
  std::string tag(1, '"');
  tag.append(std::to_string(session.version)).append(1, '-').append(kInstanceTag).append(1, '"');
  return tag;
}

MemoryBudget::Reservation reserveMemory(const ApiContext& context, uint64_t bytes,
                                        std::string_view what) {
  if (context.memory == nullptr) return {};
  return context.memory->reserve(bytes, what);
}

void requireApiKey(const ApiContext& context, const httplib::Request& req) {
  if (!context.config.apiKey) return;
  std::optional<std::string> key;
  const std::string authorization(protocol::headers::kAuthorization);
  if (req.has_header(authorization)) key = bearerToken(req.get_header_value(authorization));
  if (!key || !constantTimeEquals(*key, *context.config.apiKey)) {
    throw ProblemError(unauthorized(
        "This server needs its API key to create a session: Authorization: Bearer <key>."));
  }
}

SessionPtr authorizeSession(const ApiContext& context, const httplib::Request& req,
                            bool allowQueryToken) {
  // A viewer token may GET (read, watch); everything else changes the session.
  const bool reads = req.method == "GET" || req.method == "HEAD";
  return context.sessions.authorize(req.matches[1].str(), credentialsOf(req), allowQueryToken,
                                    reads ? Role::viewer : Role::owner);
}

uint64_t unsignedParameter(const httplib::Request& req, const std::string& name, uint64_t fallback,
                           uint64_t min, uint64_t max) {
  if (!req.has_param(name)) return fallback;
  const std::string text = req.get_param_value(name);
  uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < min ||
      value > max) {
    throw ProblemError(invalidParameter(name, "\"" + name + "\" must be an integer from " +
                                                  std::to_string(min) + " to " +
                                                  std::to_string(max) + ", not " +
                                                  quoteClientText(text) + "."));
  }
  return value;
}

}  // namespace myriad::service
