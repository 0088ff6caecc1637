// The protocol library on its own (no GPU, no server): every schema accepts its example in
// protocol/examples/, the example survives JSON -> C++ type -> JSON unchanged, the request schemas
// reject wrong types, missing and unknown members and out-of-range numbers with the right JSON
// Pointer and a message naming the member (cases in tests/protocol/cases.json, which the
// protocol-differential test also runs through python3-jsonschema), and the rules across members.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/schema_bundle.h"
#include "protocol/types.h"
#include "protocol/validate.h"

using nlohmann::json;
namespace protocol = myriad::protocol;

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in.good(), "cannot open " << path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A body's example: protocol/examples/NAME.json, or (newer schemas) the schema's own first
// `examples` item; one of the two, never both.
json example(std::string_view name) {
  const std::string path = std::string(MYRIAD_PROTOCOL_DIR) + "/examples/" + std::string(name) + ".json";
  const json& inSchema = protocol::schema(name);
  const bool inline_ = inSchema.contains("examples");
  const bool file = std::filesystem::exists(path);
  REQUIRE_MESSAGE(inline_ != file, name << ": an example in protocol/examples/ or in the schema's "
                                           "\"examples\", exactly one of them");
  return file ? json::parse(readFile(path)) : inSchema["examples"].at(0);
}

// JSON -> the schema's C++ type -> JSON.
template <class T>
json throughType(const json& j) {
  return json(j.get<T>());
}

const std::map<std::string, std::function<json(const json&)>, std::less<>> kRoundTrips = {
    {"session-create", throughType<protocol::SessionCreate>},
    {"snapshot", throughType<protocol::Snapshot>},
    {"session-created", throughType<protocol::SessionCreated>},
    {"session-state", throughType<protocol::SessionState>},
    {"model-source", throughType<protocol::ModelSource>},
    {"camera", throughType<protocol::Camera>},
    {"camera-patch", throughType<protocol::CameraPatch>},
    {"camera-select", throughType<protocol::CameraSelect>},
    {"settings", throughType<protocol::Settings>},
    {"settings-patch", throughType<protocol::SettingsPatch>},
    {"material", throughType<protocol::Material>},
    {"material-patch", throughType<protocol::MaterialPatch>},
    {"materials-list", throughType<protocol::MaterialsList>},
    {"light", throughType<protocol::Light>},
    {"light-new", throughType<protocol::LightNew>},
    {"light-patch", throughType<protocol::LightPatch>},
    {"lights-add", throughType<protocol::LightsAdd>},
    {"lights-added", throughType<protocol::LightsAdded>},
    {"lights-generate", throughType<protocol::LightsGenerate>},
    {"lights-generated", throughType<protocol::LightsGenerated>},
    {"lights-page", throughType<protocol::LightsPage>},
    {"stats", throughType<protocol::Stats>},
    {"info", throughType<protocol::Info>},
    {"models-list", throughType<protocol::ModelsList>},
    {"problem", throughType<protocol::Problem>},
    {"health", throughType<protocol::Health>},
    {"token-create", throughType<protocol::TokenCreate>},
    {"token-created", throughType<protocol::TokenCreated>},
    {"light-pick", throughType<protocol::LightPick>},
    {"asset", throughType<protocol::Asset>},
    {"assets-list", throughType<protocol::AssetsList>},
    {"object", throughType<protocol::Object>},
    {"object-new", throughType<protocol::ObjectNew>},
    {"object-patch", throughType<protocol::ObjectPatch>},
    {"objects-add", throughType<protocol::ObjectsAdd>},
    {"objects-added", throughType<protocol::ObjectsAdded>},
    {"objects-page", throughType<protocol::ObjectsPage>},
    {"labels", throughType<protocol::Labels>},
    {"clock", throughType<protocol::Clock>},
    {"clock-patch", throughType<protocol::ClockPatch>},
};

// The bodies clients send; each must reject every kind of mistake (cases.json "kind").
const std::set<std::string> kRequestSchemas = {
    "session-create", "snapshot", "model-source", "camera",      "camera-patch", "camera-select", "settings-patch",
    "material-patch", "light-new",    "light-patch", "lights-add",   "lights-generate", "token-create",
    "object-new",     "object-patch", "objects-add", "clock-patch"};

std::vector<std::string_view> bodySchemas() {
  std::vector<std::string_view> names;
  for (std::string_view name : protocol::schemaNames()) {
    if (name != "defs") names.push_back(name);
  }
  return names;
}

}  // namespace

TEST_CASE("every schema is embedded as it is on disk and accepts its example") {
  CHECK(bodySchemas().size() == 41);
  for (std::string_view name : protocol::schemaNames()) {
    CAPTURE(name);
    std::string path = std::string(MYRIAD_PROTOCOL_DIR) + "/schemas/" + std::string(name) + ".schema.json";
    CHECK(protocol::schemaText(name) == readFile(path));
    CHECK(protocol::schema(name)["$id"] ==
          "https://myriad.dev/schemas/v1/" + std::string(name) + ".schema.json");
  }
  for (std::string_view name : bodySchemas()) {
    CAPTURE(name);
    auto error = protocol::validate(name, example(name));
    CHECK_MESSAGE(!error, (error ? error->pointer + ": " + error->message : ""));
  }
}

// Bodies only one server handler reads, declared in its file with protocol/members.h (their
// members are exercised through the route by the API tests): POST .../objects/{oid}/duplicate.
const std::set<std::string_view> kHandlerBodies = {"object-duplicate"};

// A body declared as a handler file declares one (members.h), round-tripping the example it
// mirrors: absent members stay absent, null stays null, nested types convert by their own lists.
struct HandlerBody {
  std::optional<std::string> name;
  std::optional<protocol::Transform> transform;
  std::optional<protocol::Nullable<uint64_t>> parent;
  std::optional<bool> children;
};
template <class F>
void members(protocol::Tag<HandlerBody>, F f) {
  f("name", &HandlerBody::name);
  f("transform", &HandlerBody::transform);
  f("parent", &HandlerBody::parent);
  f("children", &HandlerBody::children);
}
MYRIAD_PROTOCOL_MEMBERWISE(HandlerBody)

TEST_CASE("a body declared with protocol/members.h survives JSON -> C++ type -> JSON") {
  const json full = example("object-duplicate");
  CHECK(full["parent"].is_null());
  CHECK(json(full.get<HandlerBody>()) == full);
  const json some = json::parse(R"({"transform": {"translation": [2, 0, 0]}, "parent": 7})");
  const HandlerBody body = some.get<HandlerBody>();
  CHECK_FALSE(body.name);
  CHECK_FALSE(body.children);
  REQUIRE(body.parent);
  CHECK(body.parent->value == 7u);
  CHECK(json(body) == some);
  CHECK(json(json::object().get<HandlerBody>()) == json::object());
}

TEST_CASE("every example survives JSON -> C++ type -> JSON unchanged") {
  for (std::string_view name : bodySchemas()) {
    CAPTURE(name);
    if (kHandlerBodies.contains(name)) continue;
    auto roundTrip = kRoundTrips.find(name);
    REQUIRE_MESSAGE(roundTrip != kRoundTrips.end(), "no C++ type for schema " << name);
    json original = example(name);
    json again = roundTrip->second(original);
    CHECK(again == original);
    CHECK(!protocol::validate(name, again));
  }
}

TEST_CASE("optional members stay absent, null frames stay null") {
  json patch = json::parse(R"({"fovY": 30})");
  CHECK(json(patch.get<protocol::CameraPatch>()) == patch);
  json empty = json::object();
  CHECK(json(empty.get<protocol::SessionCreate>()) == empty);
  CHECK(json(empty.get<protocol::SettingsPatch>()) == empty);
  json generate = json::parse(R"({"count": 3, "seed": 9})");
  auto request = generate.get<protocol::LightsGenerate>();
  CHECK(request.replaces());
  CHECK(!request.bounds);
  CHECK(json(request) == generate);
  json stats = example("stats");
  stats["frame"] = nullptr;
  stats["culling"] = nullptr;
  CHECK(!protocol::validate("stats", stats));
  CHECK(json(stats.get<protocol::Stats>()) == stats);
}

TEST_CASE("cases.json: valid bodies pass, each mistake is named with its JSON Pointer") {
  json cases = json::parse(readFile(MYRIAD_PROTOCOL_CASES));
  REQUIRE(cases.size() > 50);
  std::map<std::string, std::set<std::string>> kinds;
  for (const json& c : cases) {
    std::string schema = c["schema"];
    CAPTURE(schema);
    CAPTURE(c["body"].dump());
    kinds[schema].insert(c["kind"].get<std::string>());
    auto error = protocol::validate(schema, c["body"]);
    if (c["valid"]) {
      CHECK_MESSAGE(!error, (error ? error->pointer + ": " + error->message : ""));
      continue;
    }
    REQUIRE(error);
    CHECK(error->pointer == c["pointer"].get<std::string>());
    CHECK_MESSAGE(error->message.find(c["mentions"].get<std::string>()) != std::string::npos,
                  "message: " << error->message);
    CHECK(error->message.back() == '.');
  }
  for (const std::string& name : kRequestSchemas) {
    CAPTURE(name);
    CHECK(kinds[name].count("wrong-type"));
    CHECK(kinds[name].count("unknown-member"));
    CHECK(kinds[name].count("out-of-range"));
    // Patches (and session-create) have no required member; the rest must reject a missing one.
    if (protocol::schema(name).contains("required")) CHECK(kinds[name].count("missing-member"));
  }
}

TEST_CASE("parseBody: not JSON, empty, numbers out of range, then the schema") {
  auto notJson = protocol::parseBody("camera", R"({"eye": [0, 1,)");
  REQUIRE(!notJson.ok());
  CHECK(notJson.error->pointer == "");
  CHECK(notJson.error->message.find("not valid JSON") != std::string::npos);
  CHECK(notJson.error->message.find("parse error") != std::string::npos);

  auto trailing = protocol::parseBody("health", R"({"status": "ok"} x)");
  REQUIRE(!trailing.ok());
  CHECK(trailing.error->pointer == "");

  auto empty = protocol::parseBody("session-create", "");
  REQUIRE(!empty.ok());
  CHECK(empty.error->message == "The body is empty; it must be a JSON object.");

  auto huge = protocol::parseBody("camera-patch", R"({"fovY": 1e400})");
  REQUIRE(!huge.ok());
  CHECK(huge.error->pointer == "");
  CHECK(huge.error->message.find("out of range") != std::string::npos);

  auto invalid = protocol::parseBody("camera-patch", R"({"fovY": 0})");
  REQUIRE(!invalid.ok());
  CHECK(invalid.error->pointer == "/fovY");
  CHECK(invalid.error->message == "\"fovY\" must be at least 1, got 0.");

  auto fine = protocol::parseBody("camera-patch", R"({"fovY": 50})");
  CHECK(fine.ok());
  CHECK(fine.json["fovY"] == 50);
}

TEST_CASE("messages: whole sentences that name the member, escaped pointers, short quotes") {
  auto error = protocol::validate("settings-patch", json::parse(R"({"a/b~c": 1})"));
  REQUIRE(error);
  CHECK(error->pointer == "/a~1b~0c");  // RFC 6901 escaping
  CHECK(error->message ==
        "\"a~1b~0c\" is not a member of the body; its members are ambient, animate, antialias, "
        "background, environment, exposure, fog, markers, shadows, sun, suns, technique.");

  error = protocol::validate("camera", json::array());
  REQUIRE(error);
  CHECK(error->pointer == "");
  CHECK(error->message == "The body must be an object, got an array.");

  error = protocol::validate("model-source", json{{"source", std::string(5000, 'x')}});
  REQUIRE(error);
  CHECK(error->message.size() < 200);  // the 5000 characters are not echoed back

  // Shortened on a character boundary (byte 60 of the quote falls inside a character here): the
  // message stays valid UTF-8.
  std::string accents;
  for (int i = 0; i < 100; ++i) accents += "\xc3\xa9";  // U+00E9, two bytes each
  error = protocol::validate("model-source", json{{"source", "xy" + accents}});
  REQUIRE(error);
  CHECK_NOTHROW((void)json(error->message).dump());  // dump() throws on invalid UTF-8

  error = protocol::validate("settings-patch", json::parse(R"({"technique": "fast"})"));
  REQUIRE(error);
  std::string techniques;  // "\"volumes\", \"tiled\", \"clustered\"", whatever the techniques are
  for (std::string_view name : protocol::kTechniques) {
    techniques += (techniques.empty() ? "\"" : ", \"") + std::string(name) + "\"";
  }
  CHECK(error->message ==
        "\"technique\" must be one of " + techniques + "; got the string \"fast\".");
}

TEST_CASE("an unknown schema name is a programming error") {
  CHECK_THROWS_AS(protocol::validate("cameras", json::object()), std::invalid_argument);
  CHECK_THROWS_AS(protocol::parseBody("nope", "{}"), std::invalid_argument);
}

TEST_CASE("rules across members: camera, sun, generate ranges and bounds") {
  protocol::Camera camera = example("camera").get<protocol::Camera>();
  CHECK(!protocol::checkCamera(camera));

  protocol::Camera farBeforeNear = camera;
  farBeforeNear.far = camera.near;
  auto error = protocol::checkCamera(farBeforeNear);
  REQUIRE(error);
  CHECK(error->pointer == "/far");

  protocol::Camera noView = camera;
  noView.target = noView.eye;
  error = protocol::checkCamera(noView);
  REQUIRE(error);
  CHECK(error->pointer == "/target");

  protocol::Camera upAlongView = camera;
  upAlongView.up = {camera.target[0] - camera.eye[0], camera.target[1] - camera.eye[1],
                    camera.target[2] - camera.eye[2]};
  for (double& c : upAlongView.up) c *= -3;  // parallel, opposite, scaled: still parallel
  error = protocol::checkCamera(upAlongView);
  REQUIRE(error);
  CHECK(error->pointer == "/up");
  CHECK(error->message.find("parallel") != std::string::npos);

  protocol::CameraPatch patch = json::parse(R"({"far": 0.01})").get<protocol::CameraPatch>();
  error = protocol::checkCamera(protocol::applied(camera, patch));
  REQUIRE(error);  // a patch is checked on the camera it produces
  CHECK(error->pointer == "/far");

  CHECK(!protocol::checkSunDirection({0, -1, 0}));
  error = protocol::checkSunDirection({0, 0, 0});
  REQUIRE(error);
  CHECK(error->pointer == "/sun/direction");

  auto generate = example("lights-generate").get<protocol::LightsGenerate>();
  CHECK(!protocol::checkLightsGenerate(generate));
  generate.radius = protocol::Range{2, 1};
  error = protocol::checkLightsGenerate(generate);
  REQUIRE(error);
  CHECK(error->pointer == "/radius/1");
  generate.radius.reset();
  generate.intensity = protocol::Range{5, 4};
  error = protocol::checkLightsGenerate(generate);
  REQUIRE(error);
  CHECK(error->pointer == "/intensity/1");
  generate.intensity.reset();
  generate.bounds = protocol::Bounds{{0, 0, 0}, {1, -1, 1}};
  error = protocol::checkLightsGenerate(generate);
  REQUIRE(error);
  CHECK(error->pointer == "/bounds/max/1");
  CHECK(error->message == "\"bounds/max/1\" must not be less than \"bounds/min/1\".");
}

TEST_CASE("patches apply member by member") {
  auto settings = example("settings").get<protocol::Settings>();
  auto patch = example("settings-patch").get<protocol::SettingsPatch>();
  auto patched = protocol::applied(settings, patch);
  CHECK(patched.sun.intensity == 5.0);
  CHECK(patched.sun.direction == settings.sun.direction);  // sun members patch individually
  CHECK(patched.technique == "tiled");
  CHECK(patched.exposure == 1.5);
  CHECK(patched.background == settings.background);

  auto light = example("light").get<protocol::Light>();
  auto lightPatched = protocol::applied(light, example("light-patch").get<protocol::LightPatch>());
  CHECK(lightPatched.id == light.id);
  CHECK(lightPatched.intensity == 8.0);
  CHECK(lightPatched.position == light.position);

  auto material = example("material").get<protocol::Material>();
  auto materialPatched =
      protocol::applied(material, example("material-patch").get<protocol::MaterialPatch>());
  CHECK(materialPatched.roughness == doctest::Approx(0.2));
  CHECK(materialPatched.metallic == material.metallic);
  CHECK(materialPatched.name == material.name);

  auto withId = protocol::withId(example("light-new").get<protocol::LightNew>(), 99);
  CHECK(withId.id == 99);
  CHECK(!protocol::validate("light", json(withId)));
}

TEST_CASE("constants agree with the schemas") {
  const json& problem = protocol::schema("problem");
  std::set<std::string> limitNames(problem["properties"]["limit"]["enum"].begin(),
                                   problem["properties"]["limit"]["enum"].end());
  const json& info = protocol::schema("info");
  for (const auto& name : limitNames) CHECK(info["properties"]["limits"]["properties"].contains(name));

  const json& techniques = protocol::schema("defs")["$defs"]["technique"]["enum"];
  REQUIRE(techniques.size() == protocol::kTechniques.size());
  for (size_t i = 0; i < techniques.size(); ++i) CHECK(techniques[i] == protocol::kTechniques[i]);
  const json& modes = protocol::schema("defs")["$defs"]["environmentMode"]["enum"];
  REQUIRE(modes.size() == protocol::kEnvironmentModes.size());
  for (size_t i = 0; i < modes.size(); ++i) CHECK(modes[i] == protocol::kEnvironmentModes[i]);
  const json& antialias = protocol::schema("defs")["$defs"]["antialias"]["enum"];
  REQUIRE(antialias.size() == protocol::kAntialiasModes.size());
  for (size_t i = 0; i < antialias.size(); ++i) CHECK(antialias[i] == protocol::kAntialiasModes[i]);
  const json& localShadows = protocol::schema("defs")["$defs"]["localShadows"]["enum"];
  REQUIRE(localShadows.size() == protocol::kLocalShadowModes.size());
  for (size_t i = 0; i < localShadows.size(); ++i) {
    CHECK(localShadows[i] == protocol::kLocalShadowModes[i]);
  }

  for (std::string_view name : protocol::problems::kAll) {
    std::string uri = protocol::problemTypeUri(name);
    CHECK(!protocol::validate("problem", json{{"type", uri}, {"title", "t"}, {"status", 400}, {"detail", "d"}}));
    CHECK(protocol::problemTypeName(uri) == name);
  }
  CHECK(protocol::problemTypeName("https://myriad.dev/problems/nonsense").empty());
  CHECK(protocol::problemTypeName("about:blank").empty());

  CHECK(protocol::expandRoute(protocol::routes::kSessionLight, "id", "s-0123456789abcdef") ==
        "/v1/sessions/s-0123456789abcdef/lights/{lid}");
  CHECK(protocol::expandRoute(protocol::expandRoute(protocol::routes::kSessionLight, "id", "s-1"), "lid", "7") ==
        "/v1/sessions/s-1/lights/7");
  CHECK(protocol::schema("lights-add")["properties"]["lights"]["maxItems"] == protocol::kMaxLightsPerAdd);
  CHECK(protocol::schema("lights-page")["properties"]["lights"]["maxItems"] ==
        protocol::query::kMaxLightsPageLimit);
}

TEST_CASE("technique and target names: each once, and the examples use only them") {
  auto isTechnique = [](const json& name) {
    return std::find(protocol::kTechniques.begin(), protocol::kTechniques.end(),
                     name.get<std::string>()) != protocol::kTechniques.end();
  };
  auto isTarget = [](const json& name) {
    return std::find(protocol::kTargets.begin(), protocol::kTargets.end(),
                     name.get<std::string>()) != protocol::kTargets.end();
  };
  const json info = example("info");
  CHECK(!info["techniques"].empty());
  for (const json& name : info["techniques"]) CHECK(isTechnique(name));
  CHECK(isTechnique(info["defaultTechnique"]));
  CHECK(!info["targets"].empty());
  for (const json& name : info["targets"]) CHECK(isTarget(name));
  CHECK(isTechnique(example("settings")["technique"]));
  CHECK(isTechnique(example("stats")["frame"]["technique"]));
  CHECK(isTarget(example("stats")["frame"]["target"]));
  CHECK(std::set<std::string_view>(protocol::kTechniques.begin(), protocol::kTechniques.end()).size() ==
        protocol::kTechniques.size());
  CHECK(std::set<std::string_view>(protocol::kTargets.begin(), protocol::kTargets.end()).size() ==
        protocol::kTargets.size());
}

TEST_CASE("the largest lights-add body validates quickly") {
  json lights = json::array();
  json light = example("light-new");
  for (size_t i = 0; i < protocol::kMaxLightsPerAdd; ++i) lights.push_back(light);
  json body = {{"lights", lights}};
  auto start = std::chrono::steady_clock::now();
  CHECK(!protocol::validate("lights-add", body));
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE("validated 100000 lights in " << seconds << " s");
  CHECK(seconds < 5.0);  // generous for a loaded 2-core CI machine; ~0.2 s expected

  body["lights"].push_back(light);
  auto error = protocol::validate("lights-add", body);
  REQUIRE(error);
  CHECK(error->pointer == "/lights");
  CHECK(error->message == "\"lights\" must have at most 100000 items, got 100001.");
}

TEST_CASE("hostile bodies: deep nesting, a full 1 MiB body, many threads") {
  // The parser and the validator do not recurse into what the schema does not describe, so depth
  // cannot exhaust the stack.
  auto unclosed = protocol::parseBody("camera", std::string(1000000, '['));
  REQUIRE(!unclosed.ok());
  CHECK(unclosed.error->pointer == "");
  auto deep = protocol::parseBody("camera-patch",
                                  "{\"eye\":" + std::string(200000, '[') + std::string(200000, ']') + "}");
  REQUIRE(!deep.ok());
  CHECK(deep.error->pointer == "/eye");
  CHECK(deep.error->message == "\"eye\" must have exactly 3 items, got 1.");

  // About the most lights a 1 MiB body (maxBodyBytes' default) holds.
  std::string body = "{\"lights\":[";
  size_t count = 0;
  while (body.size() < (1u << 20) - 200) {
    if (count++ > 0) body += ",";
    body += example("light-new").dump();
  }
  body += "]}";
  auto start = std::chrono::steady_clock::now();
  auto parsed = protocol::parseBody("lights-add", body);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE("parsed and validated a " << body.size() << "-byte body of " << count << " lights in "
                                    << seconds << " s");
  CHECK(parsed.ok());
  CHECK(parsed.json["lights"].size() == count);

  // The server validates on many HTTP threads at once; the bundle is built once, then read-only.
  std::vector<std::thread> threads;
  std::vector<int> failures(8, 0);
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([t, &failures] {
      for (int i = 0; i < 200; ++i) {
        json camera = {{"eye", {t, i, 1}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}},
                       {"fovY", 1 + (i % 200)}, {"near", 0.1}, {"far", 10}};
        bool valid = !protocol::validate("camera", camera);
        if (valid != (1 + (i % 200) <= 179)) ++failures[t];
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int f : failures) CHECK(f == 0);
}

namespace {

// Every object node closes its members, every array says what its items are, every number has a
// range, every string a bound or a pattern (or is an enum/const): the house rules for schemas.
void checkHouseRules(const json& node, const std::string& where, std::vector<std::string>& broken) {
  auto types = node.contains("type") ? (node["type"].is_array() ? node["type"] : json::array({node["type"]}))
                                     : json::array();
  for (const json& type : types) {
    if (type == "object" && node.value("additionalProperties", json(true)) != json(false)) {
      broken.push_back(where + ": object without additionalProperties: false");
    }
    if (type == "array" && !node.contains("items")) broken.push_back(where + ": array without items");
    if ((type == "number" || type == "integer") && !node.contains("minimum") &&
        !node.contains("exclusiveMinimum") && !node.contains("maximum")) {
      broken.push_back(where + ": number without a range");
    }
  }
  if (node.contains("properties")) {
    for (const auto& [key, sub] : node["properties"].items()) checkHouseRules(sub, where + "/properties/" + key, broken);
  }
  if (node.contains("$defs")) {
    for (const auto& [key, sub] : node["$defs"].items()) checkHouseRules(sub, where + "/$defs/" + key, broken);
  }
  if (node.contains("items")) checkHouseRules(node["items"], where + "/items", broken);
}

}  // namespace

TEST_CASE("schemas follow the house rules") {
  std::vector<std::string> broken;
  for (std::string_view name : protocol::schemaNames()) {
    const json& schema = protocol::schema(name);
    CAPTURE(name);
    CHECK(schema["$schema"] == "https://json-schema.org/draft/2020-12/schema");
    CHECK(schema["title"].is_string());
    CHECK(schema["description"].is_string());
    checkHouseRules(schema, std::string(name), broken);
  }
  for (const std::string& b : broken) MESSAGE(b);
  CHECK(broken.empty());
}
