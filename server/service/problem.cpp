#include "service/problem.h"

#include "protocol/constants.h"

namespace myriad::service {
namespace {

// Enough to recognise a value in an error message; longer values are cut.
constexpr size_t kMaxQuotedLength = 64;

// `type` is a problem's NAME (protocol::problems); the body carries its URI.
Problem make(int status, std::string_view type, std::string title, std::string detail,
             std::optional<std::string> parameter = std::nullopt) {
  Problem problem;
  problem.status = status;
  problem.type = protocol::problemTypeUri(type);
  problem.title = std::move(title);
  problem.detail = std::move(detail);
  problem.parameter = std::move(parameter);
  return problem;
}

}  // namespace

nlohmann::json toJson(const Problem& problem) {
  nlohmann::json body = {
      {"type", problem.type},
      {"title", problem.title},
      {"status", problem.status},
      {"detail", problem.detail},
  };
  if (problem.parameter) body["parameter"] = *problem.parameter;
  if (problem.pointer) body["pointer"] = *problem.pointer;
  if (problem.limit) body["limit"] = *problem.limit;
  return body;
}

std::string toBody(const Problem& problem) {
  return toJson(problem).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

Problem invalidParameter(std::string parameter, std::string detail) {
  return make(400, protocol::problems::kInvalidParameter, "Invalid query parameter",
              std::move(detail), std::move(parameter));
}

Problem unknownParameter(std::string parameter, std::string detail) {
  return make(400, protocol::problems::kUnknownParameter, "Unknown query parameter",
              std::move(detail), std::move(parameter));
}

Problem notFound(std::string_view path) {
  return make(
      404, protocol::problems::kNotFound, "Not found",
      "There is no resource at " + quoteClientText(path) + "; see GET /v1/info for the API.");
}

Problem methodNotAllowed(std::string_view method, std::string_view path, std::string_view allow) {
  return make(405, protocol::problems::kMethodNotAllowed, "Method not allowed",
              quoteClientText(path) + " does not support " + quoteClientText(method) +
                  "; allowed: " + std::string(allow) + ".");
}

Problem badRequest(int status, std::string detail) {
  return make(status, protocol::problems::kBadRequest, "Bad request", std::move(detail));
}

Problem serverBusy(std::string detail) {
  return make(503, protocol::problems::kServerBusy, "Server busy", std::move(detail));
}

Problem renderFailed(std::string detail) {
  return make(500, protocol::problems::kRenderFailed, "Rendering failed", std::move(detail));
}

Problem internalError(std::string detail) {
  return make(500, protocol::problems::kInternalError, "Internal server error", std::move(detail));
}

Problem invalidBody(std::string pointer, std::string detail) {
  Problem p =
      make(400, protocol::problems::kInvalidBody, "Invalid request body", std::move(detail));
  p.pointer = std::move(pointer);
  return p;
}

Problem unauthorized(std::string detail) {
  return make(401, protocol::problems::kUnauthorized, "Unauthorized", std::move(detail));
}

Problem forbidden(std::string detail) {
  return make(403, protocol::problems::kForbidden, "Forbidden", std::move(detail));
}

Problem unsupportedMediaType(std::string detail) {
  return make(415, protocol::problems::kUnsupportedMediaType, "Unsupported media type",
              std::move(detail));
}

Problem limitExceeded(int status, std::string limit, std::string detail) {
  Problem p = make(status, protocol::problems::kLimitExceeded, "Limit exceeded", std::move(detail));
  p.limit = std::move(limit);
  // Sessions expire and requests finish within seconds; a client retrying sooner only adds load.
  if (status == 429) p.retryAfterSeconds = 1;
  return p;
}

Problem modelRejected(std::string detail) {
  return make(422, protocol::problems::kModelRejected, "Model rejected", std::move(detail));
}

Problem environmentRejected(std::string detail) {
  return make(422, protocol::problems::kEnvironmentRejected, "Environment image rejected",
              std::move(detail));
}

Problem conflict(std::string detail) {
  return make(409, protocol::problems::kConflict, "Conflict", std::move(detail));
}

Problem preconditionFailed(std::string detail) {
  return make(412, protocol::problems::kPreconditionFailed, "Precondition failed",
              std::move(detail));
}

Problem notFoundDetail(std::string detail) {
  return make(404, protocol::problems::kNotFound, "Not found", std::move(detail));
}

std::string quoteClientText(std::string_view text) {
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "\"" + std::string(...).
  std::string quoted(1, '"');
  quoted.append(text.substr(0, kMaxQuotedLength));
  if (text.size() > kMaxQuotedLength) quoted += "...";
  quoted += '"';
  return quoted;
}

}  // namespace myriad::service
