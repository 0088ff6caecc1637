#include "protocol/openapi.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <regex>
#include <stdexcept>
#include <string>

#include "protocol/constants.h"
#include "protocol/operations.h"
#include "protocol/schema_bundle.h"

namespace myriad::protocol {
namespace {

using nlohmann::json;

constexpr std::string_view kComponentPrefix = "#/components/schemas/";
constexpr std::string_view kDefsSchema = "defs";  // defs.schema.json: shared $defs only

std::string componentRef(std::string_view name) {
  return std::string(kComponentPrefix) + std::string(name);
}

// A $ref of schema `owner` as it points in the OpenAPI document.
std::string rewriteRef(const std::string& ref, std::string_view owner) {
  static const std::regex local(R"(^#/\$defs/([A-Za-z0-9_-]+)$)");
  static const std::regex file(R"(^([a-z0-9-]+)\.schema\.json(#/\$defs/([A-Za-z0-9_-]+))?$)");
  std::smatch m;
  std::string schemaName(owner);
  std::string def;
  if (std::regex_match(ref, m, local)) {
    def = m[1];
  } else if (std::regex_match(ref, m, file)) {
    schemaName = m[1];
    def = m[3];
    schema(schemaName);  // throws for an unknown schema
  } else {
    throw std::logic_error("openapi: cannot place the $ref \"" + ref + "\" of " +
                           std::string(owner) + ".schema.json");
  }
  if (def.empty()) {
    if (schemaName == kDefsSchema) {
      throw std::logic_error("openapi: " + std::string(owner) +
                             ".schema.json refers to defs.schema.json as a whole");
    }
    return componentRef(schemaName);
  }
  if (schemaName == kDefsSchema) return componentRef(def);
  return componentRef(schemaName) + "/$defs/" + def;
}

void rewriteRefs(json& node, std::string_view owner) {
  if (node.is_array()) {
    for (json& item : node) rewriteRefs(item, owner);
    return;
  }
  if (!node.is_object()) return;
  for (auto& [key, value] : node.items()) {
    if (key == "$ref" && value.is_string()) {
      value = rewriteRef(value.get<std::string>(), owner);
    } else if (key == "properties" && value.is_object()) {
      // Member names are not keywords: a member called "$ref" would be a schema, not a link.
      for (auto& [member, memberSchema] : value.items()) rewriteRefs(memberSchema, owner);
    } else {
      rewriteRefs(value, owner);
    }
  }
}

void addComponent(json& schemas, const std::string& name, json schema) {
  if (schemas.contains(name)) {
    throw std::logic_error("openapi: two components named \"" + name + "\"");
  }
  schemas[name] = std::move(schema);
}

// Path parameters by their name in route templates.
json pathParameter(std::string_view name) {
  json schema;
  std::string description;
  if (name == "id") {
    schema = {{"type", "string"}, {"pattern", "^s-[0-9a-f]{16}$"}};
    description = "The session id (s- and 16 hex digits).";
  } else if (name == "mid") {
    schema = {{"$ref", componentRef("materialId")}};
    description = "A material id: its index in the session's model.";
  } else if (name == "lid") {
    schema = {{"$ref", componentRef("lightId")}};
    description = "A light id, as the server assigned it.";
  } else if (name == "aid") {
    schema = {{"$ref", componentRef("assetId")}};
    description = "An asset id (a- and 16 hex digits of its content's SHA-256).";
  } else if (name == "oid") {
    schema = {{"$ref", componentRef("objectId")}};
    description = "An object id, as the server assigned it.";
  } else if (name == "file") {
    schema = {{"type", "string"}, {"minLength", 1}};
    description = "A file of the web client.";
  } else {
    throw std::logic_error("openapi: no description of the path parameter {" + std::string(name) +
                           "}");
  }
  return {{"name", name},
          {"in", "path"},
          {"required", true},
          {"description", description},
          {"schema", schema}};
}

json pathParameters(std::string_view route) {
  json parameters = json::array();
  for (size_t open = route.find('{'); open != std::string_view::npos;
       open = route.find('{', open + 1)) {
    const size_t close = route.find('}', open);
    parameters.push_back(pathParameter(route.substr(open + 1, close - open - 1)));
  }
  return parameters;
}

json headerObject(std::string_view name) {
  static const std::map<std::string_view, std::pair<std::string_view, std::string_view>> known = {
      {headers::kServerTiming,
       {"string",
        "GPU time per pass in frame order, then readback and encode, in milliseconds "
        "(gbuffer;dur=2.113, ...); for the compute techniques a last entry "
        "culling;desc=\"...\" says what light culling did."}},
      {headers::kTechnique, {"string", "The technique that shaded the frame."}},
      {headers::kWidth, {"integer", "raw frames: the image width in pixels."}},
      {headers::kHeight, {"integer", "raw frames: the image height in pixels."}},
      {headers::kChannels, {"string", "raw frames: the channel names, comma-separated, in order."}},
      {headers::kTarget, {"string", "raw frames: the target."}},
      {headers::kIntrinsics,
       {"string", "JSON {fx, fy, cx, cy, width, height, near, far}: the pinhole intrinsics in "
                  "pixels (OpenCV convention: u = fx x/z + cx, v = fy y/z + cy, (0, 0) the "
                  "top-left corner of the image) and the clip planes."}},
      {headers::kPose,
       {"string", "JSON {worldFromCamera: 4 rows of 4}: camera space (x right, y down, z "
                  "forward) to world space."}},
      {headers::kDepth, {"string", "raw depth: its convention, z or distance."}},
      {headers::kSpace, {"string", "raw position and normal: their axes, world or camera."}},
      {headers::kDtype,
       {"string", "raw frames: the values' type, float32, or uint32 for the label targets "
                  "(instance-id, semantic-id, material-id)."}},
      {headers::kTargets,
       {"string", "npz and exr frames: the targets the file holds, comma-separated, in order."}},
      {headers::kFrameTime, {"number", "Session frames: the animation time shown, in seconds."}},
      {headers::kFrameVersion, {"integer", "Session frames: the session version shown."}},
      {headers::kDepthScale,
       {"number", "png16 depth: metres per unit of its 16-bit values (0.001: millimetres)."}},
      {headers::kRetryAfter, {"integer", "Seconds to wait before retrying."}},
      {headers::kAllow, {"string", "The methods the route allows."}},
      {headers::kLocation, {"string", "The new session's URL."}},
      {headers::kETag,
       {"string", "Session routes: the session's version as an entity tag, as this answer saw it "
                  "(after the edit, for an edit). Send it as If-Match to make an edit "
                  "conditional."}},
      {headers::kVideoCodec,
       {"string", "Video streams: the codec string for WebCodecs' VideoDecoder and Media "
                  "Source Extensions (vp8, vp09.00.10.08, avc1.42C0 and the H.264 level in hex)."}},
  };
  auto it = known.find(name);
  if (it == known.end()) {
    throw std::logic_error("openapi: no description of the header " + std::string(name));
  }
  return {{"description", it->second.second}, {"schema", {{"type", it->second.first}}}};
}

json content(const std::vector<Content>& forms) {
  json out = json::object();
  for (const Content& c : forms) {
    json media = json::object();
    if (!c.schema.empty()) {
      schema(c.schema);  // throws for an unknown schema
      media["schema"] = {{"$ref", componentRef(c.schema)}};
    }
    out[std::string(c.mediaType)] = media;
  }
  return out;
}

json problemResponse(int status) {
  static const std::map<int, std::string_view> descriptions = {
      {400,
       "A query parameter (invalid-parameter, unknown-parameter; `parameter` names it) or "
       "the body (invalid-body; `pointer` names the member) is wrong."},
      {401,
       "unauthorized: no or a malformed Authorization: Bearer, a token of no open session, "
       "or (creating a session) not the API key."},
      {403, "forbidden: the token of another session."},
      {404,
       "not-found: no such session (or it expired or was deleted), material, light, asset, "
       "object, library model or file."},
      {409, "conflict: the asset is still in use (an object draws it or one of its materials)."},
      {412,
       "precondition-failed: If-Match names no longer the session's version (ETag); the "
       "answer's ETag is the current one. Nothing was changed."},
      {413,
       "limit-exceeded: the body, the upload, the light, object or asset count is over its limit "
       "(`limit` names it)."},
      {415, "unsupported-media-type: a body with a Content-Type this route does not take."},
      {422,
       "model-rejected (or environment-rejected for an .hdr): the loader failed (parse error, "
       "crash, time or memory limit, an image over its size limit)."},
      {429, "limit-exceeded: too many sessions, streams or requests in flight (`limit` names it)."},
      {500, "render-failed or internal-error; the server keeps serving."},
      {503, "server-busy: the render queue (or every loader slot) is full."},
  };
  auto it = descriptions.find(status);
  if (it == descriptions.end()) {
    throw std::logic_error("openapi: no description of a " + std::to_string(status) + " problem");
  }
  json response = {{"description", it->second},
                   {"content",
                    {{std::string(kProblemContentType),
                      {{"schema", {{"$ref", componentRef(schema_names::kProblem)}}}}}}}};
  if (status == 429 || status == 503) {
    response["headers"][std::string(headers::kRetryAfter)] = headerObject(headers::kRetryAfter);
  }
  return response;
}

json security(Access access) {
  switch (access) {
    case Access::Public:
      return nullptr;
    case Access::ApiKeyWhenSet:
      return json::array({json::object(), {{"apiKey", json::array()}}});
    case Access::Session:
      return json::array({{{"sessionToken", json::array()}}});
    case Access::SessionOrQueryToken:
      return json::array({{{"sessionToken", json::array()}}, {{"queryToken", json::array()}}});
  }
  return nullptr;
}

// A route under /v1/sessions/{id}: its answers carry the session's ETag, its edits take If-Match.
bool sessionResource(const Operation& op) {
  return op.route.starts_with(std::string(routes::kSessions) + "/{id}");
}

json operationObject(const Operation& op) {
  json out = {{"operationId", op.id}, {"tags", {op.tag}}, {"summary", op.summary}};
  const bool conditional = sessionResource(op) && op.method != "GET";
  if (conditional) {
    out["parameters"].push_back(
        {{"name", headers::kIfMatch},
         {"in", "header"},
         {"required", false},
         {"description",
          "An ETag of this session (or *): the edit applies only while the session is at that "
          "version, else 412 precondition-failed. Without it the edit applies to the latest "
          "version."},
         {"schema", {{"type", "string"}}}});
  }
  if (!op.query.empty()) {
    json parameters = json::array();
    for (const QueryParameter& p : op.query) {
      parameters.push_back({{"name", p.name},
                            {"in", "query"},
                            {"required", p.required},
                            {"description", p.description},
                            {"schema", p.schema}});
    }
    for (json& p : parameters) out["parameters"].push_back(std::move(p));
  }
  if (!op.body.empty()) {
    out["requestBody"] = {{"required", op.bodyRequired}, {"content", content(op.body)}};
  }
  json responses = json::object();
  for (const Response& r : op.responses) {
    json response = {{"description", r.description}};
    if (!r.content.empty()) response["content"] = content(r.content);
    for (std::string_view header : r.headers) {
      response["headers"][std::string(header)] = headerObject(header);
    }
    if (sessionResource(op) && r.status < 300) {
      response["headers"][std::string(headers::kETag)] = headerObject(headers::kETag);
    }
    responses[std::to_string(r.status)] = response;
  }
  for (int status : op.problems) responses[std::to_string(status)] = problemResponse(status);
  if (conditional) {
    json precondition = problemResponse(412);
    precondition["headers"][std::string(headers::kETag)] = headerObject(headers::kETag);
    responses["412"] = precondition;
  }
  responses["default"] = {
      {"description",
       "Any other problem (RFC 9457; see protocol/reference.md, Errors): 405 with Allow for "
       "another method, 429 when the server handles too many requests, 500."},
      {"content",
       {{std::string(kProblemContentType),
         {{"schema", {{"$ref", componentRef(schema_names::kProblem)}}}}}}}};
  out["responses"] = responses;
  if (json s = security(op.access); !s.is_null()) out["security"] = s;
  return out;
}

std::string lowercase(std::string_view method) {
  std::string out(method);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

json openApiComponentSchemas(const std::vector<std::string_view>& targets) {
  json schemas = json::object();
  for (std::string_view name : schemaNames()) {
    json s = schema(name);
    s.erase("$schema");
    s.erase("$id");
    rewriteRefs(s, name);
    if (name == kDefsSchema) {
      for (auto& [def, defSchema] : s.at("$defs").items()) addComponent(schemas, def, defSchema);
    } else {
      addComponent(schemas, std::string(name), std::move(s));
    }
  }
  json target = {{"title", "Target"},
                 {"description",
                  "What a frame shows: final (tonemapped, sRGB) or a G-buffer or debug view; "
                  "GET /v1/info lists them."},
                 {"type", "string"}};
  if (!targets.empty()) target["enum"] = targets;
  addComponent(schemas, "target", target);
  addComponent(schemas, "format",
               {{"title", "Format"},
                {"description", "How a frame's pixels are sent: PNG, JPEG or raw float32."},
                {"enum", kFormats}});
  return schemas;
}

json openApiDocument(const OpenApiOptions& options) {
  json paths = json::object();
  json tags = json::array();
  for (const Operation& op : operations()) {
    const std::string route(op.route);
    if (!paths.contains(route)) {
      paths[route] = json::object();
      if (json parameters = pathParameters(op.route); !parameters.empty()) {
        paths[route]["parameters"] = parameters;
      }
    }
    const std::string method = lowercase(op.method);
    if (paths[route].contains(method)) {
      throw std::logic_error("openapi: " + std::string(op.method) + " " + route + " twice");
    }
    paths[route][method] = operationObject(op);
    if (std::find(tags.begin(), tags.end(), json{{"name", op.tag}}) == tags.end()) {
      tags.push_back({{"name", op.tag}});
    }
  }
  return {
      {"openapi", "3.1.0"},
      {"info",
       {{"title", "Myriad HTTP API"},
        {"version", options.version},
        {"summary", "A Vulkan deferred renderer for scenes lit by very many lights, over HTTP."},
        {"description",
         "Version 1 of the protocol (/v1/...). Sessions hold a scene each (model, camera, "
         "settings, materials, lights); frames come as PNG, JPEG, raw float32 or a multipart "
         "stream. Every error is an RFC 9457 problem (application/problem+json) whose type is "
         "https://myriad.dev/problems/NAME. protocol/reference.md is the user's reference."}}},
      {"tags", tags},
      {"paths", paths},
      {"components",
       {{"schemas", openApiComponentSchemas(options.targets)},
        {"securitySchemes",
         {{"sessionToken",
           {{"type", "http"},
            {"scheme", "bearer"},
            {"description", "The session's token, as POST /v1/sessions returned it."}}},
          {"queryToken",
           {{"type", "apiKey"},
            {"in", "query"},
            {"name", query::kToken},
            {"description",
             "The session's token as ?token= (frames and streams only, for an <img>); the "
             "Authorization header wins when both are sent."}}},
          {"apiKey",
           {{"type", "http"},
            {"scheme", "bearer"},
            {"description",
             "The server's --api-key (or MYRIAD_API_KEY); needed to create a session only when "
             "the server has one (GET /v1/info apiKeyRequired)."}}}}}}},
  };
}

}  // namespace myriad::protocol
