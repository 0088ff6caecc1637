// The operation table and the OpenAPI document built from it, without a server: one entry per
// method and route, schemas that exist, every $ref of the document resolving, the schemas of
// protocol/schemas placed under components with their references rewritten. The `openapi` CTest
// validates the served document with an OpenAPI validator and checks it against the server.
#include <doctest/doctest.h>

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/openapi.h"
#include "protocol/operations.h"
#include "protocol/schema_bundle.h"

using nlohmann::json;
namespace protocol = myriad::protocol;

namespace {

bool isSchema(std::string_view name) {
  for (std::string_view known : protocol::schemaNames()) {
    if (known == name) return true;
  }
  return false;
}

// RFC 6901: "~" -> "~0", "/" -> "~1".
std::string escapePointerToken(const std::string& token) {
  std::string out;
  for (char c : token) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

// Every "$ref" string under `node`, with its JSON Pointer.
void collectRefs(const json& node, const std::string& where,
                 std::vector<std::pair<std::string, std::string>>& out) {
  if (node.is_array()) {
    for (size_t i = 0; i < node.size(); ++i)
      collectRefs(node[i], where + "/" + std::to_string(i), out);
  } else if (node.is_object()) {
    for (const auto& [key, value] : node.items()) {
      if (key == "$ref" && value.is_string()) {
        out.emplace_back(where, value.get<std::string>());
      } else {
        collectRefs(value, where + "/" + escapePointerToken(key), out);
      }
    }
  }
}

}  // namespace

TEST_CASE("operations: each method and route once, with known schemas and unique ids") {
  std::set<std::pair<std::string_view, std::string_view>> keys;
  std::set<std::string_view> ids;
  const std::set<std::string_view> methods = {"GET", "POST", "PUT", "PATCH", "DELETE"};
  for (const protocol::Operation& op : protocol::operations()) {
    CAPTURE(op.method);
    CAPTURE(op.route);
    CHECK(methods.count(op.method) == 1);
    CHECK(keys.emplace(op.method, op.route).second);
    CHECK(ids.emplace(op.id).second);
    CHECK(!op.summary.empty());
    CHECK(!op.responses.empty());
    CHECK(protocol::findOperation(op.method, op.route) == &op);
    for (const protocol::Content& c : op.body) CHECK((c.schema.empty() || isSchema(c.schema)));
    for (const protocol::Response& r : op.responses) {
      CHECK(r.status >= 200);
      CHECK(r.status < 300);
      for (const protocol::Content& c : r.content) CHECK((c.schema.empty() || isSchema(c.schema)));
    }
    for (int status : op.problems) {
      CHECK(status >= 400);
      CHECK(status < 600);
    }
  }
  CHECK(protocol::findOperation("GET", "/v1/no-such-route") == nullptr);
  // ?token= is a query parameter of exactly the routes an <img> reads.
  const protocol::Operation* frame =
      protocol::findOperation("GET", protocol::routes::kSessionFrame);
  REQUIRE(frame != nullptr);
  const auto names = protocol::queryParameterNames(*frame);
  CHECK(std::count(names.begin(), names.end(), protocol::query::kToken) == 1);
  const protocol::Operation* camera =
      protocol::findOperation("GET", protocol::routes::kSessionCamera);
  REQUIRE(camera != nullptr);
  CHECK(protocol::queryParameterNames(*camera).empty());
}

TEST_CASE("openapi: one path per route, every operation, every $ref resolves") {
  const json doc = protocol::openApiDocument({"9.9.9", {"final", "depth"}});
  CHECK(doc.at("openapi") == "3.1.0");
  CHECK(doc.at("info").at("version") == "9.9.9");
  CHECK(!doc.contains("jsonSchemaDialect"));  // OpenAPI's default: 2020-12 and its vocabulary

  std::set<std::string> routes;
  for (const protocol::Operation& op : protocol::operations()) {
    routes.emplace(op.route);
    std::string method(op.method);
    for (char& c : method) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    CAPTURE(op.route);
    REQUIRE(doc.at("paths").contains(std::string(op.route)));
    const json& item = doc.at("paths").at(std::string(op.route));
    REQUIRE(item.contains(method));
    CHECK(item.at(method).at("operationId") == op.id);
    // Every {name} of the template is a path parameter of the path item.
    const std::string route(op.route);
    for (size_t open = route.find('{'); open != std::string::npos;
         open = route.find('{', open + 1)) {
      const std::string name = route.substr(open + 1, route.find('}', open) - open - 1);
      bool found = false;
      for (const json& p : item.at("parameters"))
        found = found || (p.at("name") == name && p.at("in") == "path");
      CHECK_MESSAGE(found, "no path parameter " << name);
    }
  }
  CHECK(doc.at("paths").size() == routes.size());

  std::vector<std::pair<std::string, std::string>> refs;
  collectRefs(doc, "", refs);
  CHECK(refs.size() > 50);
  for (const auto& [where, ref] : refs) {
    CAPTURE(where);
    CAPTURE(ref);
    REQUIRE(ref.rfind("#/", 0) == 0);
    CHECK(doc.contains(json::json_pointer(ref.substr(1))));
  }
}

TEST_CASE("openapi: the schemas of protocol/schemas are components, $refs rewritten") {
  const json schemas = protocol::openApiComponentSchemas();
  for (std::string_view name : protocol::schemaNames()) {
    if (name == "defs") continue;
    CAPTURE(name);
    REQUIRE(schemas.contains(std::string(name)));
    const json& s = schemas.at(std::string(name));
    CHECK(!s.contains("$id"));
    CHECK(!s.contains("$schema"));
    // Everything else as in the file.
    json original = protocol::schema(name);
    original.erase("$id");
    original.erase("$schema");
    CHECK(s.at("title") == original.at("title"));
    CHECK(s.value("required", json::array()) == original.value("required", json::array()));
  }
  // defs.schema.json's definitions are components of their own.
  for (const auto& [def, schema] : protocol::schema("defs").at("$defs").items()) {
    CHECK(schemas.contains(def));
  }
  CHECK(!schemas.contains("defs"));
  CHECK(schemas.at("camera").at("properties").at("eye").at("$ref") == "#/components/schemas/vec3");
  CHECK(schemas.at("bounds").at("properties").at("min").at("$ref") == "#/components/schemas/vec3");
  CHECK(schemas.at("session-state").at("properties").at("settings").at("$ref") ==
        "#/components/schemas/settings");
  CHECK(schemas.at("format").at("enum") == json(protocol::kFormats));
  CHECK(schemas.at("technique").at("enum") == json(protocol::kTechniques));
  // Without a list of targets, any string; with one, exactly those.
  CHECK(!schemas.at("target").contains("enum"));
  CHECK(protocol::openApiComponentSchemas({"final", "depth"}).at("target").at("enum") ==
        json::array({"final", "depth"}));
}
