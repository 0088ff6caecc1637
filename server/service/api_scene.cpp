// A session's camera, settings and materials: parse, authorize, one SessionScene edit, answer.
// Camera and settings live only on the CPU (each frame carries them to the renderer); a material
// edit is queued on the session's GPU scene under the session's lock.
#include "loader/library.h"
#include "loader/loader.h"
#include "protocol/constants.h"
#include "protocol/types.h"
#include "service/api.h"
#include "render/render_queue.h"
#include "service/session_json.h"

namespace myriad::service {
namespace {

// The aspect ratio a framed camera assumes: the web client's and most frames' 16:9.
constexpr float kFramingAspect = 16.0f / 9.0f;

// A request that takes no body may still arrive with "{}" (some clients always send one).
void requireNoBody(const httplib::Request& req) {
  if (req.body.empty()) return;
  nlohmann::json body = nlohmann::json::parse(req.body, nullptr, false);
  if (!body.is_object() || !body.empty()) {
    throw ProblemError(invalidBody("", "This request takes no body (or an empty object {})."));
  }
}

void getCamera(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->scene.camera()));
}

// X-Myriad-Interaction: "end" (the last change of a drag or a slider), absent, or a 400.
bool endsInteraction(const httplib::Request& req) {
  const std::string name(protocol::headers::kInteraction);
  if (!req.has_header(name)) return false;
  if (req.get_header_value(name) == protocol::headers::kInteractionEnd) return true;
  throw ProblemError(badRequest(400, name + " must be \"" +
                                         std::string(protocol::headers::kInteractionEnd) +
                                         "\" when present."));
}

// PUT (whole camera) and PATCH (any subset): both must leave a valid camera.
void setCamera(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res,
               bool patch) {
  SessionPtr session = requestSession();
  nlohmann::json body =
      jsonBody(req, patch ? protocol::schema_names::kCameraPatch : protocol::schema_names::kCamera);
  const bool ends = endsInteraction(req);
  auto lock = lockOpen(*session);
  if (patch) {
    session->scene.patchCamera(body.get<protocol::CameraPatch>());
  } else {
    session->scene.setCamera(fromWire(body.get<protocol::Camera>()));
  }
  session->bump(ends);
  sendJson(res, toWire(session->scene.camera()));
}

void frameCamera(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  requireNoBody(req);
  auto lock = lockOpen(*session);
  session->scene.frameModel(kFramingAspect);
  session->bump();
  sendJson(res, toWire(session->scene.camera()));
}

void selectCamera(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto body =
      jsonBody(req, protocol::schema_names::kCameraSelect).get<protocol::CameraSelect>();
  auto lock = lockOpen(*session);
  session->scene.selectModelCamera(body.modelCamera);
  session->bump();
  sendJson(res, toWire(session->scene.camera()));
}

void getSettings(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->scene));
}

void patchSettings(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto patch =
      jsonBody(req, protocol::schema_names::kSettingsPatch).get<protocol::SettingsPatch>();
  const bool ends = endsInteraction(req);
  auto lock = lockOpen(*session);
  session->scene.patchSettings(patch, Clock::now());
  session->bump(ends);
  sendJson(res, toWire(session->scene));
}

// A loader refusal of an environment image as its problem.
Problem environmentProblem(const loader::ModelRejected& e) {
  if (e.reason == "busy") {
    Problem p = serverBusy(std::string(e.what()) + " Retry in a few seconds.");
    p.retryAfterSeconds = 5;
    return p;
  }
  if (e.reason == "internal") return internalError(e.what());
  return environmentRejected(std::string(e.what()) + " (" + e.reason + ")");
}

// The environment image of PUT .../environment: an .hdr upload (image/vnd.radiance or
// application/octet-stream, ?filename= for messages) or {"source": "library:NAME.hdr"}. Decoded in
// the loader child; a refusal is 422 environment-rejected naming the problem.
std::shared_ptr<const scene::EnvironmentImage> loadEnvironment(const ApiContext& context,
                                                               const httplib::Request& req,
                                                               std::string& source) {
  const std::string type = req.get_header_value("Content-Type");
  try {
    if (type.starts_with(protocol::kRadianceContentType) ||
        type.starts_with(protocol::kUploadContentType)) {
      std::string filename = "upload.hdr";
      if (req.has_param("filename")) {
        filename = req.get_param_value("filename");
        if (filename.empty() || filename.size() > 255 || filename.find('/') != std::string::npos ||
            filename.find('\\') != std::string::npos) {
          throw ProblemError(invalidParameter(
              "filename", "\"filename\" must be a file name of at most 255 bytes without slashes."));
        }
      }
      source = std::string(protocol::kUploadPrefix) + filename;
      return std::make_shared<const scene::EnvironmentImage>(
          loader::loadEnvironmentBytes(req.body, filename));
    }
    if (type.starts_with(protocol::kJsonContentType)) {
      if (req.has_param("filename")) {
        throw ProblemError(invalidParameter(
            "filename", "\"filename\" goes with an .hdr upload, not JSON."));
      }
      source = jsonBody(req, protocol::schema_names::kModelSource).get<protocol::ModelSource>().source;
      return loadLibraryEnvironment(context, source);
    }
  } catch (const loader::ModelRejected& e) {
    throw ProblemError(environmentProblem(e));
  }
  throw ProblemError(unsupportedMediaType(
      "PUT .../environment takes the .hdr itself (image/vnd.radiance or "
      "application/octet-stream) or application/json {\"source\": \"library:NAME.hdr\"}, not " +
      quoteClientText(type.empty() ? std::string("no Content-Type") : type) + "."));
}

void putEnvironment(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  std::string source;
  // Decoding takes the loader's time; the session stays usable meanwhile.
  std::shared_ptr<const scene::EnvironmentImage> image = loadEnvironment(context, req, source);
  // With --state-dir, an uploaded image is kept (decoded: 384 KiB) for a restore; a library one
  // is named by the snapshot.
  std::optional<std::string> stored;
  if (context.state != nullptr && source.starts_with(protocol::kUploadPrefix)) {
    stored = context.state->putBlob(std::string_view(
        reinterpret_cast<const char*>(image->rgb.data()), image->rgb.size() * sizeof(float)));
  }
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    session->persisted.environmentBlob = std::move(stored);
    // Queued under the lock, so a frame after this edit sees the image.
    uploaded = context.renderThread.setEnvironmentImage(session->sceneId, image);
    session->scene.setEnvironmentImage(std::move(image), source);
    session->bump();
  }
  uploaded.get();
  std::lock_guard lock(session->mutex);
  sendJson(res, toWire(session->scene));
}

void getMaterials(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  const std::vector<scene::Material>& materials = session->scene.materials();
  protocol::MaterialsList list;
  list.materials.reserve(materials.size());
  for (uint32_t i = 0; i < materials.size(); ++i) list.materials.push_back(toWire(i, materials[i], session->scene.model().images));
  sendJson(res, list);
}

void patchMaterial(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto patch =
      jsonBody(req, protocol::schema_names::kMaterialPatch).get<protocol::MaterialPatch>();
  const bool ends = endsInteraction(req);
  std::future<void> uploaded;
  protocol::Material result;
  {
    auto lock = lockOpen(*session);
    SessionScene& scene = session->scene;
    const uint32_t id = scene.materialId(req.matches[2].str());
    uploaded = context.renderThread.updateMaterials(session->sceneId,
                                                    {scene.patchMaterial(id, patch)});
    session->bump(ends);
    result = toWire(id, scene.materials()[id], scene.model().images);
  }
  uploaded.get();
  sendJson(res, result);
}

}  // namespace

std::shared_ptr<const scene::EnvironmentImage> loadLibraryEnvironment(const ApiContext& context,
                                                                      const std::string& source) {
  const std::string_view name = source.starts_with(protocol::kLibraryPrefix)
                                    ? std::string_view(source).substr(protocol::kLibraryPrefix.size())
                                    : std::string_view();
  std::optional<std::filesystem::path> path;
  if (context.models != nullptr && !name.empty()) path = context.models->resolveEnvironment(name);
  if (!path) {
    throw ProblemError(notFoundDetail(
        "There is no environment image " + quoteClientText(source) +
        " in the server's library: give \"library:NAME.hdr\", a Radiance .hdr under the "
        "--models directory" +
        (context.models == nullptr ? std::string(" (this server has none).") : ".")));
  }
  try {
    return std::make_shared<const scene::EnvironmentImage>(loader::loadEnvironmentFile(*path));
  } catch (const loader::ModelRejected& e) {
    throw ProblemError(environmentProblem(e));
  }
}

void addSceneRoutes(Routes& routes, ApiContext& context) {
  auto bind = [&context](ContextHandler handler) { return bindContext(context, handler); };
  routes.add("GET", protocol::routes::kSessionCamera, bind(getCamera));
  routes.add("PUT", protocol::routes::kSessionCamera,
             [&context](const httplib::Request& req, httplib::Response& res) {
               setCamera(context, req, res, false);
             });
  routes.add("PATCH", protocol::routes::kSessionCamera,
             [&context](const httplib::Request& req, httplib::Response& res) {
               setCamera(context, req, res, true);
             });
  routes.add("POST", protocol::routes::kSessionCameraFrame, bind(frameCamera));
  routes.add("POST", protocol::routes::kSessionCameraSelect, bind(selectCamera));
  routes.add("GET", protocol::routes::kSessionSettings, bind(getSettings));
  routes.add("PATCH", protocol::routes::kSessionSettings, bind(patchSettings));
  RouteOptions upload;
  upload.maxBodyBytes = context.config.limits.maxUploadBytes;
  upload.bodyLimitName = "maxUploadBytes";
  routes.add("PUT", protocol::routes::kSessionEnvironment, bind(putEnvironment), upload);
  routes.add("GET", protocol::routes::kSessionMaterials, bind(getMaterials));
  routes.add("PATCH", protocol::routes::kSessionMaterial, bind(patchMaterial));
}

}  // namespace myriad::service
