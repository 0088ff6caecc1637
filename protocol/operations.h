// Every operation of the v1 API, listed once: method, route, what it takes (query parameters,
// body) and what it answers (statuses, media types, schemas, headers). GET /v1/openapi.json is
// built from this table and the schemas (openapi.h); the server refuses to start when its route
// table differs from it, and the `openapi` CTest holds protocol/reference.md to it.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace myriad::protocol {

// Who may call an operation.
enum class Access {
  Public,               // anyone
  ApiKeyWhenSet,        // anyone, or only with --api-key's key when the server has one
  Session,              // the session's token in Authorization: Bearer
  SessionOrQueryToken,  // the same, or ?token= (for an <img>, which cannot send headers)
};

// One media type of a body. `schema` names a schema of protocol/schemas (schema_names::); empty
// for a body that is not JSON (images, floats, a model file, text).
struct Content {
  std::string_view mediaType;
  std::string_view schema;
};

struct QueryParameter {
  std::string_view name;
  nlohmann::json schema;  // JSON Schema; may $ref "#/components/schemas/NAME" (see openapi.h)
  std::string description;
  bool required = false;
};

struct Response {
  int status = 200;
  std::string_view description;
  std::vector<Content> content;           // empty: no body
  std::vector<std::string_view> headers;  // names from headers:: (openapi.cpp describes each)
};

struct Operation {
  std::string_view method;  // "GET", "POST", "PUT", "PATCH" or "DELETE"; GET also answers HEAD
  std::string_view route;   // a routes:: template
  std::string_view id;      // operationId: unique, lowerCamelCase
  std::string_view tag;     // the section of protocol/reference.md
  std::string_view summary;
  Access access = Access::Public;
  std::vector<QueryParameter> query;  // every query parameter it takes (any other is a 400)
  // The query string is not the server's to check: the web client's page and files are fetched
  // with the page's own options (?stream=jpeg, a cache-busting ?v=), which its scripts read.
  bool anyQuery = false;
  std::vector<Content> body;          // the request body's accepted forms; empty: none
  bool bodyRequired = true;
  std::vector<Response> responses;  // what success looks like
  std::vector<int> problems;        // statuses it answers with a problem body
};

// The table, in protocol/reference.md's order.
const std::vector<Operation>& operations();

// The operation for `method` on `route`, or nullptr.
const Operation* findOperation(std::string_view method, std::string_view route);

// The names of an operation's query parameters (what the server's checkQuery() allows), with
// "token" for SessionOrQueryToken operations.
std::vector<std::string_view> queryParameterNames(const Operation& operation);

}  // namespace myriad::protocol
