// The v1 API as an OpenAPI 3.1 document (GET /v1/openapi.json), built from the operation table
// (operations.h) and the JSON Schemas of protocol/schemas, so that it cannot disagree with them.
//
// The schemas are draft 2020-12, the dialect OpenAPI 3.1 builds on, so they go in unchanged but
// for three things: each becomes components/schemas/NAME (NAME.schema.json), the shared
// definitions of defs.schema.json become components of their own (components/schemas/vec3, ...),
// and every $ref is rewritten to point there ("defs.schema.json#/$defs/vec3" ->
// "#/components/schemas/vec3"); $id and $schema are dropped, since an $id would make those
// references resolve against the schema's own URI instead of the document. The document keeps
// OpenAPI's default dialect (2020-12 plus OpenAPI's vocabulary), so validators check the schemas
// too.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace myriad::protocol {

struct OpenApiOptions {
  std::string version = "1";              // info.version: the server's version
  std::vector<std::string_view> targets;  // the values of frames' `target`; empty: any string
};

nlohmann::json openApiDocument(const OpenApiOptions& options = {});

// components/schemas alone: every schema of protocol/schemas with its $refs rewritten, the
// definitions of defs.schema.json, "format" (kFormats) and "target" (`targets`). Throws
// std::logic_error for a $ref it cannot place or two components of one name.
nlohmann::json openApiComponentSchemas(const std::vector<std::string_view>& targets = {});

}  // namespace myriad::protocol
