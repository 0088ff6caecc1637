// RFC 9457 problem details: the body of every error response. Each kind of problem has a type URI,
// https://myriad.dev/problems/NAME with NAME from protocol::problems (listed in
// protocol/reference.md), so clients can branch on the type rather than on the English title or
// detail.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace myriad::service {

struct Problem {
  int status = 500;
  std::string type;                      // protocol::problemTypeUri(protocol::problems::k...)
  std::string title;                     // the same for every problem of this type
  std::string detail;                    // this occurrence, naming what was wrong
  std::optional<std::string> parameter;  // the offending query parameter, when there is one
  std::optional<std::string> pointer;    // JSON Pointer to the offending body member
  std::optional<std::string> limit;      // the limit's name as in /v1/info "limits"
  // Sent as the Retry-After header (429, 503), not in the body.
  std::optional<int> retryAfterSeconds;
};

// A handler's way out with a problem: the route wrapper (api.h) catches it and answers with it.
class ProblemError : public std::exception {
 public:
  explicit ProblemError(Problem problem) : problem_(std::move(problem)) {}
  const Problem& problem() const { return problem_; }
  const char* what() const noexcept override { return problem_.detail.c_str(); }

 private:
  Problem problem_;
};

nlohmann::json toJson(const Problem& problem);

// The response body. Never throws on client-supplied text: invalid UTF-8 is replaced.
std::string toBody(const Problem& problem);

Problem invalidParameter(std::string parameter, std::string detail);
Problem unknownParameter(std::string parameter, std::string detail);
Problem notFound(std::string_view path);
Problem methodNotAllowed(std::string_view method, std::string_view path, std::string_view allow);
Problem badRequest(int status, std::string detail);
Problem serverBusy(std::string detail);
Problem renderFailed(std::string detail);
Problem internalError(std::string detail);
// 400 invalid-body; `pointer` is "" for the whole body.
Problem invalidBody(std::string pointer, std::string detail);
Problem unauthorized(std::string detail);
Problem forbidden(std::string detail);
Problem unsupportedMediaType(std::string detail);
// 413 (sizes, counts) or 429 (sessions, streams, requests; Retry-After set) limit-exceeded.
Problem limitExceeded(int status, std::string limit, std::string detail);
Problem modelRejected(std::string detail);
// 422 environment-rejected: an .hdr the loader refused (`detail` names the problem).
Problem environmentRejected(std::string detail);
// 404 not-found for a thing that does not exist (a session, light, material or model).
Problem notFoundDetail(std::string detail);
// 409 conflict: the request contradicts the session's state (an asset still in use).
Problem conflict(std::string detail);
// 412: an If-Match that names no longer the session's version (api.h lockOpen).
Problem preconditionFailed(std::string detail);

// Client-supplied text quoted in a detail: shortened, so a huge query cannot produce a huge
// error body.
std::string quoteClientText(std::string_view text);

}  // namespace myriad::service
