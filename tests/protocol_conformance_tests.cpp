// The real server against the protocol: every JSON body myriad-server answers on every route of
// protocol/CONTRACT.md conforms to its schema (protocol/schemas/), every error is a problem+json
// body that conforms to problem.schema.json with a status equal to the HTTP status, and the values
// the server sends back read into the shared C++ types. This is what keeps the schemas, the
// reference and the server from drifting apart.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "protocol/constants.h"
#include "protocol/types.h"
#include "protocol/validate.h"
#include "server_process.h"

using myriad::test::ApiClient;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using nlohmann::json;
namespace protocol = myriad::protocol;
namespace fs = std::filesystem;

namespace {

constexpr const char* kBox = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// CHECKs that `reply` is `status` with a JSON body of schema `schemaName`; returns the body.
json conforming(const Reply& reply, int status, std::string_view schemaName, const std::string& what) {
  INFO(what << " -> " << reply.status << " " << reply.body.substr(0, 600));
  CHECK(reply.status == status);
  CHECK(reply.header("Content-Type").rfind("application/json", 0) == 0);
  auto error = protocol::validate(schemaName, reply.json);
  CHECK_MESSAGE(!error, std::string(schemaName) << (error ? " " + error->pointer + ": " + error->message : ""));
  return reply.json;
}

// CHECKs an error answer: problem+json, conforming, its status the HTTP status, its type one of
// ours and the expected one.
void conformingProblem(const Reply& reply, int status, std::string_view typeName, const std::string& what) {
  INFO(what << " -> " << reply.status << " " << reply.body.substr(0, 600));
  CHECK(reply.status == status);
  CHECK(reply.header("Content-Type").rfind(std::string(protocol::kProblemContentType), 0) == 0);
  auto error = protocol::validate(protocol::schema_names::kProblem, reply.json);
  CHECK_MESSAGE(!error, (error ? error->pointer + ": " + error->message : ""));
  if (error) return;
  auto problem = reply.json.get<protocol::Problem>();
  CHECK(problem.status == reply.status);
  CHECK(protocol::problemTypeName(problem.type) == typeName);
}

}  // namespace

TEST_CASE("protocol conformance: every route's JSON answer matches its schema") {
  const fs::path models = fs::temp_directory_path() / ("myriad-conformance-" + std::to_string(::getpid()));
  fs::create_directories(models / "sub");
  fs::copy_file(kBox, models / "box.glb", fs::copy_options::overwrite_existing);
  fs::copy_file(kBox, models / "sub" / "box2.glb", fs::copy_options::overwrite_existing);
  struct RemoveDir {
    fs::path path;
    ~RemoveDir() { fs::remove_all(path); }
  } removeModels{models};

  ServerProcess server({"--models", models.string(), "--lights", "16", "--max-resolution", "256"});
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);

  // Server-wide.
  conforming(api.get("/v1/health"), 200, "health", "GET /v1/health");
  json info = conforming(api.get("/v1/info"), 200, "info", "GET /v1/info");
  json library = conforming(api.get("/v1/models"), 200, "models-list", "GET /v1/models");
  CHECK(library["models"].size() == 2);

  // A session's life.
  Reply createdReply = api.post("/v1/sessions", R"({"model":"builtin:default"})");
  json created = conforming(createdReply, 201, "session-created", "POST /v1/sessions");
  REQUIRE(created.contains("token"));
  const std::string token = created["token"];
  const std::string session = protocol::expandRoute(protocol::routes::kSession, "id", created["id"].get<std::string>());
  auto route = [&](std::string_view templ) {
    return protocol::expandRoute(templ, "id", created["id"].get<std::string>());
  };
  conforming(api.get(session, token), 200, "session-state", "GET session");

  json camera = conforming(api.get(route(protocol::routes::kSessionCamera), token), 200, "camera", "GET camera");
  conforming(api.put(route(protocol::routes::kSessionCamera), camera.dump(), token), 200, "camera", "PUT camera");
  conforming(api.patch(route(protocol::routes::kSessionCamera), R"({"fovY":40})", token), 200, "camera", "PATCH camera");
  conforming(api.post(route(protocol::routes::kSessionCameraFrame), "", token), 200, "camera", "POST camera/frame");

  conforming(api.get(route(protocol::routes::kSessionSettings), token), 200, "settings", "GET settings");
  conforming(api.patch(route(protocol::routes::kSessionSettings), R"({"sun":{"intensity":2},"technique":"tiled"})", token),
             200, "settings", "PATCH settings");

  json materials = conforming(api.get(route(protocol::routes::kSessionMaterials), token), 200, "materials-list",
                              "GET materials");
  REQUIRE(!materials["materials"].empty());
  std::string material = protocol::expandRoute(route(protocol::routes::kSessionMaterial), "mid",
                                               std::to_string(materials["materials"][0]["id"].get<uint32_t>()));
  conforming(api.patch(material, R"({"roughness":0.25})", token), 200, "material", "PATCH material");

  json added = conforming(api.post(route(protocol::routes::kSessionLights),
                                   R"({"lights":[{"position":[0,1,0],"radius":2,"color":[1,1,1],"intensity":3,"falloff":1}]})",
                                   token),
                          201, "lights-added", "POST lights");
  REQUIRE(added["ids"].size() == 1);
  std::string light = protocol::expandRoute(route(protocol::routes::kSessionLight), "lid",
                                            std::to_string(added["ids"][0].get<uint64_t>()));
  conforming(api.get(light, token), 200, "light", "GET light");
  conforming(api.patch(light, R"({"intensity":5})", token), 200, "light", "PATCH light");
  conforming(api.get(route(protocol::routes::kSessionLights) + "?offset=0&limit=5", token), 200, "lights-page",
             "GET lights");
  conforming(api.post(route(protocol::routes::kSessionLightsGenerate), R"({"count":64,"seed":3,"replace":false})", token),
             200, "lights-generated", "POST lights/generate");

  json before = conforming(api.get(route(protocol::routes::kSessionStats), token), 200, "stats", "GET stats (no frame)");
  Reply frame = api.get(route(protocol::routes::kSessionFrame) + "?width=64&height=48", token);
  CHECK(frame.status == 200);
  CHECK(frame.header("Content-Type") == "image/png");
  json after = conforming(api.get(route(protocol::routes::kSessionStats), token), 200, "stats", "GET stats");
  CHECK(after["frame"].is_object());
  CHECK(after["frames"].get<uint64_t>() > before["frames"].get<uint64_t>());

  conforming(api.put(route(protocol::routes::kSessionModel), R"({"source":"library:sub/box2.glb"})", token), 200,
             "session-state", "PUT model (library)");
  Reply uploaded = api.put(route(protocol::routes::kSessionModel) + "?filename=box.glb",
                           readFile(kBox), token, "application/octet-stream");
  json uploadedState = conforming(uploaded, 200, "session-state", "PUT model (upload)");
  CHECK(uploadedState["model"]["source"] == "upload:box.glb");

  // The raw format as reference.md describes it: N float32 per pixel, the names in a header.
  Reply raw = api.get(route(protocol::routes::kSessionFrame) + "?target=normal&format=raw&width=40&height=30", token);
  CHECK(raw.status == 200);
  CHECK(raw.header("Content-Type") == std::string(protocol::kRawContentType));
  CHECK(raw.header(std::string(protocol::headers::kChannels)) == "x,y,z");
  CHECK(raw.header(std::string(protocol::headers::kWidth)) == "40");
  CHECK(raw.header(std::string(protocol::headers::kHeight)) == "30");
  CHECK(raw.header(std::string(protocol::headers::kTarget)) == "normal");
  CHECK(raw.body.size() == 40u * 30u * 3u * 4u);

  // The stream format byte for byte: the first part opens with the boundary, and each part ends
  // with the next boundary line (browsers show a part only once it arrives).
  const std::string head = "--myriad-frame\r\nContent-Type: image/jpeg\r\nContent-Length: ";
  const std::string sequence = "\r\nX-Myriad-Frame: ";
  const std::string tail = "\r\n--myriad-frame\r\n";
  std::string stream;
  // How many bytes the first part and the boundary after it take, once the headers are in.
  auto firstPartBytes = [&]() -> std::optional<size_t> {
    size_t headersEnd = stream.find("\r\n\r\n");
    if (stream.rfind(head, 0) != 0 || headersEnd == std::string::npos) return std::nullopt;
    size_t imageBytes = std::stoul(stream.substr(head.size()));
    return headersEnd + 4 + imageBytes + tail.size();
  };
  std::string contentType;
  httplib::Headers auth = {{std::string(protocol::headers::kAuthorization), "Bearer " + token}};
  api.raw().Get(
      route(protocol::routes::kSessionStream) + "?fps=10&width=32&height=24", auth,
      [&](const httplib::Response& response) {
        contentType = response.get_header_value("Content-Type");
        return true;
      },
      [&](const char* data, size_t length) {
        stream.append(data, length);
        auto needed = firstPartBytes();
        return stream.size() < (1u << 20) && (!needed || stream.size() < *needed);  // false: stop
      });
  CHECK(contentType == std::string(protocol::kStreamContentType));
  REQUIRE(firstPartBytes());
  REQUIRE(stream.size() >= *firstPartBytes());
  size_t lengthEnd = stream.find("\r\n", head.size());
  CHECK(stream.compare(lengthEnd, sequence.size(), sequence) == 0);
  size_t imageStart = stream.find("\r\n\r\n") + 4;
  CHECK(stream.substr(imageStart, 2) == "\xff\xd8");  // a JPEG
  CHECK(stream.substr(*firstPartBytes() - tail.size(), tail.size()) == tail);

  // Errors, one of each kind a client can provoke cheaply.
  conformingProblem(api.get("/v1/nothing"), 404, protocol::problems::kNotFound, "unknown route");
  conformingProblem(api.send("PUT", "/v1/health", "", {}), 405, protocol::problems::kMethodNotAllowed, "PUT health");
  conformingProblem(api.get(route(protocol::routes::kSessionCamera)), 401, protocol::problems::kUnauthorized,
                    "no token");
  conformingProblem(api.patch(route(protocol::routes::kSessionCamera), R"({"fovY":500})", token), 400,
                    protocol::problems::kInvalidBody, "fovY out of range");
  conformingProblem(api.patch(route(protocol::routes::kSessionCamera), "{not json", token), 400,
                    protocol::problems::kInvalidBody, "not JSON");
  conformingProblem(api.patch(route(protocol::routes::kSessionCamera), R"({"fovY":50})", token, "text/plain"), 415,
                    protocol::problems::kUnsupportedMediaType, "text/plain body");
  conformingProblem(api.get(route(protocol::routes::kSessionLights) + "?limit=5000", token), 400,
                    protocol::problems::kInvalidParameter, "lights limit 5000");
  conformingProblem(api.get(route(protocol::routes::kSessionFrame) + "?sizes=3", token), 400,
                    protocol::problems::kUnknownParameter, "frame ?sizes");
  conformingProblem(api.put(route(protocol::routes::kSessionModel) + "?filename=junk.glb", "not a model", token,
                            "application/octet-stream"),
                    422, protocol::problems::kModelRejected, "upload of junk");
  conformingProblem(api.get(protocol::expandRoute(route(protocol::routes::kSessionLight), "lid", "999999"), token), 404,
                    protocol::problems::kNotFound, "unknown light");

  Reply other = api.post("/v1/sessions", "");
  json otherCreated = conforming(other, 201, "session-created", "POST /v1/sessions (empty body)");
  conformingProblem(api.get(session, otherCreated["token"]), 403, protocol::problems::kForbidden,
                    "another session's token");

  // Deletes answer 204 with no body.
  for (const std::string& path : {light, route(protocol::routes::kSessionLights), session}) {
    Reply deleted = api.del(path, token);
    CHECK_MESSAGE(deleted.status == 204, "DELETE " << path << " -> " << deleted.status << " " << deleted.body);
    CHECK(deleted.body.empty());
  }

  json infoAfter = conforming(api.get("/v1/info"), 200, "info", "GET /v1/info at the end");
  CHECK(infoAfter["validation"]["enabled"] == true);
  CHECK(infoAfter["validation"]["messages"] == 0);
  CHECK(server.stop().has_value());
}
