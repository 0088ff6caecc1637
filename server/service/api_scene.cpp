// A session's camera, settings and materials: parse, authorize, one SessionScene edit, answer.
// Camera and settings live only on the CPU (each frame carries them to the renderer); a material
// edit is queued on the session's GPU scene under the session's lock.
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

void getCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->scene.camera()));
}

// PUT (whole camera) and PATCH (any subset): both must leave a valid camera.
void setCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res,
               bool patch) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  nlohmann::json body =
      jsonBody(req, patch ? protocol::schema_names::kCameraPatch : protocol::schema_names::kCamera);
  auto lock = lockOpen(*session);
  if (patch) {
    session->scene.patchCamera(body.get<protocol::CameraPatch>());
  } else {
    session->scene.setCamera(fromWire(body.get<protocol::Camera>()));
  }
  session->bump();
  sendJson(res, toWire(session->scene.camera()));
}

void frameCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  requireNoBody(req);
  auto lock = lockOpen(*session);
  session->scene.frameModel(kFramingAspect);
  session->bump();
  sendJson(res, toWire(session->scene.camera()));
}

void getSettings(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->scene.settings()));
}

void patchSettings(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto patch =
      jsonBody(req, protocol::schema_names::kSettingsPatch).get<protocol::SettingsPatch>();
  auto lock = lockOpen(*session);
  session->scene.patchSettings(patch, Clock::now());
  session->bump();
  sendJson(res, toWire(session->scene.settings()));
}

void getMaterials(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  const std::vector<scene::Material>& materials = session->scene.materials();
  protocol::MaterialsList list;
  list.materials.reserve(materials.size());
  for (uint32_t i = 0; i < materials.size(); ++i) list.materials.push_back(toWire(i, materials[i], session->scene.model().images));
  sendJson(res, list);
}

void patchMaterial(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto patch =
      jsonBody(req, protocol::schema_names::kMaterialPatch).get<protocol::MaterialPatch>();
  std::future<void> uploaded;
  protocol::Material result;
  {
    auto lock = lockOpen(*session);
    SessionScene& scene = session->scene;
    const uint32_t id = scene.materialId(req.matches[2].str());
    uploaded = context.renderThread.updateMaterials(session->sceneId,
                                                    {scene.patchMaterial(id, patch)});
    session->bump();
    result = toWire(id, scene.materials()[id], scene.model().images);
  }
  uploaded.get();
  sendJson(res, result);
}

}  // namespace

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
  routes.add("GET", protocol::routes::kSessionSettings, bind(getSettings));
  routes.add("PATCH", protocol::routes::kSessionSettings, bind(patchSettings));
  routes.add("GET", protocol::routes::kSessionMaterials, bind(getMaterials));
  routes.add("PATCH", protocol::routes::kSessionMaterial, bind(patchMaterial));
}

}  // namespace myriad::service
