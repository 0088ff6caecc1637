// The JSON Schemas of protocol/schemas/, embedded in the binary at build time
// (protocol/embed_schemas.cmake generates the definition of embeddedSchemas()).
#pragma once

#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace myriad::protocol {

namespace detail {
struct EmbeddedSchema {
  std::string_view name;  // the file name without ".schema.json": "camera", "lights-add"
  std::string_view text;  // the file's text
};
const std::vector<EmbeddedSchema>& embeddedSchemas();
}  // namespace detail

// Every schema's name, sorted ("camera", "camera-patch", ..., "stats").
const std::vector<std::string_view>& schemaNames();

// The parsed schema of that name; throws std::invalid_argument for an unknown name (a programming
// error: names are constants of protocol/constants.h).
const nlohmann::json& schema(std::string_view name);

// The schema's text as it is in protocol/schemas/NAME.schema.json (for serving it, e.g.).
std::string_view schemaText(std::string_view name);

}  // namespace myriad::protocol
