// Checking request and response bodies against the protocol's JSON Schemas (protocol/schemas/),
// with a validator of our own for the subset of JSON Schema 2020-12 those files use: $ref within
// the bundle, type (integer included), const, enum, minimum/maximum/exclusiveMinimum/
// exclusiveMaximum, minLength/maxLength, pattern, minItems/maxItems, items, properties, required,
// additionalProperties: false. Annotations ($id, title, description, default, ...) are ignored; any
// other keyword in a schema is a programming error, reported when the bundle is first used.
//
// Beyond the schemas, a few rules relate members to each other (far > near, eye != target, ...);
// the check*() functions below test those on the converted types, after validate() passed.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "protocol/types.h"

namespace myriad::protocol {

struct ValidationError {
  std::string pointer;  // JSON Pointer (RFC 6901) to the member to blame: "/eye/1"; "" = the body
  std::string message;  // one sentence naming the member and the rule it breaks
};

// The first way `body` breaks schema `schemaName` ("camera", "lights-add": protocol/schemas/
// NAME.schema.json, see schema_names:: in constants.h), or nullopt when it conforms.
// Throws std::invalid_argument for an unknown schema name.
std::optional<ValidationError> validate(std::string_view schemaName, const nlohmann::json& body);

// A request body as received: parsed and validated, or the reason it was refused.
struct ParsedBody {
  nlohmann::json json;                   // the parsed body (null when it was not JSON)
  std::optional<ValidationError> error;  // why it is refused; nullopt = parsed and valid
  bool ok() const { return !error.has_value(); }
};

// Parses `text` as JSON (an empty body is refused too: callers that accept an empty body, like
// POST /v1/sessions, pass "{}" instead) and validates it against `schemaName`. Not JSON -> an error
// with pointer "" whose message includes the parser's reason.
ParsedBody parseBody(std::string_view schemaName, std::string_view text);

// Rules across members, for values that already passed their schema. Each returns the pointer of
// the member to blame (relative to the object checked) and a sentence, or nullopt.
std::optional<ValidationError> checkCamera(const Camera& camera);           // far > near, eye != target, up not along the view
std::optional<ValidationError> checkSunDirection(const Vec3& direction);    // non-zero ("/sun/direction")
std::optional<ValidationError> checkBounds(const Bounds& bounds, std::string_view pointer);  // min <= max
// A light's members together: direction not [0, 0, 0], innerConeAngle < outerConeAngle. Pointers
// are relative to the light; `blameOuter` names outerConeAngle for a broken cone (a patch that
// changed only it) instead of innerConeAngle.
std::optional<ValidationError> checkLight(const Light& light, bool blameOuter = false);
std::optional<ValidationError> checkLightsGenerate(const LightsGenerate& request);  // ranges ordered, bounds

}  // namespace myriad::protocol
