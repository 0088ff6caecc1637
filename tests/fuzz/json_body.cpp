// A JSON body as the server (and, for answers, the CLI) reads it: parse + schema validation
// (protocol::parseBody), then, when valid, conversion to the C++ type (get<T>()), the rules across
// members (check*()), and the trip back to JSON.
//
// Input: the first byte picks the schema (index into kBodies, modulo), the rest is the body text.
// Promises checked: parseBody throws nothing; a refusal names a parseable JSON Pointer and a
// sentence; a valid body converts without throwing and comes back from to_json unchanged (what
// types.h promises); the check*() functions throw nothing.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "fuzz_support.h"
#include "protocol/constants.h"
#include "protocol/schema_bundle.h"
#include "protocol/types.h"
#include "protocol/validate.h"

namespace protocol = myriad::protocol;
namespace names = myriad::protocol::schema_names;
using myriad::fuzz::broken;
using myriad::fuzz::require;
using nlohmann::json;

namespace {

void checkRule(const std::optional<protocol::ValidationError>& error) {
  if (!error) return;
  require(!error->message.empty(), "a rule refused a body without a sentence");
  require(error->pointer.empty() || error->pointer.front() == '/',
          "a rule's pointer is not a JSON Pointer");
}

// The trip JSON -> T -> JSON gives the body back, plus the defaults of members the schema lets a
// body leave out (a snapshot's settings without "environment" or "suns" come back with them):
// nothing the body said is changed or dropped, and a second trip changes nothing.
template <typename T>
T roundTrip(const json& body) {
  T value = body.get<T>();
  const json back = value;
  for (const json& op : json::diff(body, back)) {
    if (op.at("op") != "add") {
      broken("to_json(from_json(body)) changed or dropped what the body said (" + op.dump() +
             "): " + back.dump() + " vs " + body.dump());
    }
  }
  const json again = back.get<T>();
  if (again != back) broken("a second trip through T changed the body: " + again.dump() + " vs " + back.dump());
  return value;
}

template <typename T>
void convert(const json& body) {
  roundTrip<T>(body);
}

void convertCamera(const json& body) { checkRule(protocol::checkCamera(roundTrip<protocol::Camera>(body))); }

void convertCameraPatch(const json& body) {
  // What PATCH .../camera does: apply to the current camera, then check the result's rules.
  const auto patch = roundTrip<protocol::CameraPatch>(body);
  checkRule(protocol::checkCamera(protocol::applied(protocol::Camera{{0, 2, 6}, {0, 0, 0}}, patch)));
}

void convertSettings(const json& body) {
  checkRule(protocol::checkSunDirection(roundTrip<protocol::Settings>(body).sun.direction));
}

void convertSettingsPatch(const json& body) {
  const auto patch = roundTrip<protocol::SettingsPatch>(body);
  protocol::Settings settings;
  settings.sun.direction = {0, -1, 0};
  checkRule(protocol::checkSunDirection(protocol::applied(settings, patch).sun.direction));
}

void convertMaterialPatch(const json& body) {
  protocol::applied(protocol::Material{}, roundTrip<protocol::MaterialPatch>(body));
}

void convertLightPatch(const json& body) {
  // What PATCH .../lights/{lid} does: apply to the light, then check the whole light's rules.
  checkRule(protocol::checkLight(protocol::applied(protocol::Light{}, roundTrip<protocol::LightPatch>(body))));
}

void convertLightNew(const json& body) {
  checkRule(protocol::checkLight(protocol::withId(roundTrip<protocol::LightNew>(body), 0)));
}

void convertLightsGenerate(const json& body) {
  const auto request = roundTrip<protocol::LightsGenerate>(body);
  checkRule(protocol::checkLightsGenerate(request));
  if (request.bounds) checkRule(protocol::checkBounds(*request.bounds, "/bounds"));
}

// A snapshot holds a camera and settings: the same rules hold for them as for their own bodies.
void convertSnapshot(const json& body) {
  const auto snapshot = roundTrip<protocol::Snapshot>(body);
  checkRule(protocol::checkCamera(snapshot.camera));
  checkRule(protocol::checkSunDirection(snapshot.settings.sun.direction));
}

// A body only one server handler reads declares its type in that handler's file (protocol/members.h;
// docs/ARCHITECTURE.md, "How to add a route"), out of this harness's reach: it is fuzzed through
// parse + schema validation, and its type's trip is checked by protocol_tests ("a body declared
// with protocol/members.h ...") and the route by the API tests.
void schemaOnly(const json&) {}

struct Body {
  std::string_view schema;
  void (*convert)(const json&);
};

// Every schema of protocol/schemas with the type the server or the CLI converts it to.
// LLVMFuzzerInitialize checks that no schema is missing here.
constexpr Body kBodies[] = {
    {names::kSessionCreate, convert<protocol::SessionCreate>},
    {names::kSessionCreated, convert<protocol::SessionCreated>},
    {names::kSnapshot, convertSnapshot},
    {names::kSessionState, convert<protocol::SessionState>},
    {names::kModelSource, convert<protocol::ModelSource>},
    {names::kCamera, convertCamera},
    {names::kCameraPatch, convertCameraPatch},
    {names::kSettings, convertSettings},
    {names::kSettingsPatch, convertSettingsPatch},
    {names::kMaterial, convert<protocol::Material>},
    {names::kMaterialPatch, convertMaterialPatch},
    {names::kMaterialsList, convert<protocol::MaterialsList>},
    {names::kLight, convert<protocol::Light>},
    {names::kLightNew, convertLightNew},
    {names::kLightPatch, convertLightPatch},
    {names::kLightsAdd, convert<protocol::LightsAdd>},
    {names::kLightsAdded, convert<protocol::LightsAdded>},
    {names::kLightsGenerate, convertLightsGenerate},
    {names::kLightsGenerated, convert<protocol::LightsGenerated>},
    {names::kLightsPage, convert<protocol::LightsPage>},
    {names::kStats, convert<protocol::Stats>},
    {names::kInfo, convert<protocol::Info>},
    {names::kModelsList, convert<protocol::ModelsList>},
    {names::kProblem, convert<protocol::Problem>},
    {names::kHealth, convert<protocol::Health>},
    {names::kCameraSelect, convert<protocol::CameraSelect>},
    {names::kTokenCreate, convert<protocol::TokenCreate>},
    {names::kTokenCreated, convert<protocol::TokenCreated>},
    {names::kLightPick, convert<protocol::LightPick>},
    {names::kAsset, convert<protocol::Asset>},
    {names::kAssetsList, convert<protocol::AssetsList>},
    {names::kObject, convert<protocol::Object>},
    {names::kObjectNew, convert<protocol::ObjectNew>},
    {names::kObjectPatch, convert<protocol::ObjectPatch>},
    {names::kObjectsAdd, convert<protocol::ObjectsAdd>},
    {names::kObjectsAdded, convert<protocol::ObjectsAdded>},
    {names::kObjectsPage, convert<protocol::ObjectsPage>},
    {names::kLabels, convert<protocol::Labels>},
    {names::kClock, convert<protocol::Clock>},
    {names::kClockPatch, convert<protocol::ClockPatch>},
    {"object-duplicate", schemaOnly},  // POST .../objects/{oid}/duplicate (server/service/api_objects.cpp)
};
constexpr size_t kBodyCount = sizeof kBodies / sizeof kBodies[0];

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // "defs" holds shared definitions only; every other schema is a body and must be fuzzed.
  std::set<std::string_view> covered;
  for (const Body& body : kBodies) covered.insert(body.schema);
  for (std::string_view name : protocol::schemaNames()) {
    if (name != "defs" && !covered.contains(name)) {
      broken("schema \"" + std::string(name) + "\" has no entry in tests/fuzz/json_body.cpp");
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const Body& body = kBodies[data[0] % kBodyCount];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);

  const protocol::ParsedBody parsed = protocol::parseBody(body.schema, text);
  if (!parsed.ok()) {
    require(!parsed.error->message.empty(), "a refusal without a sentence");
    const std::string& pointer = parsed.error->pointer;
    require(pointer.empty() || pointer.front() == '/', "a refusal whose pointer is not one");
    // The problem body carries the pointer: it must be a JSON Pointer a client can follow.
    try {
      (void)json::json_pointer(pointer);
    } catch (const json::exception&) {
      broken("a refusal's pointer does not parse: " + pointer);
    }
    return 0;
  }
  body.convert(parsed.json);
  return 0;
}
