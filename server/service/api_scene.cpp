// A session's camera, settings and materials. Camera and settings live only on the CPU (each
// frame carries them to the renderer); a material edit is uploaded to the session's GPU scene.
#include <charconv>

#include "protocol/constants.h"
#include "protocol/types.h"
#include "protocol/validate.h"
#include "scene/camera.h"
#include "service/api.h"
#include "service/render_thread.h"
#include "service/session_json.h"

namespace myriad::service {
namespace {

// The aspect ratio a framed camera assumes: the web client's and most frames' 16:9.
constexpr float kFramingAspect = 16.0f / 9.0f;

void throwIfInvalid(const std::optional<protocol::ValidationError>& error) {
  if (error) throw ProblemError(invalidBody(error->pointer, error->message));
}

// A request that takes no body may still arrive with "{}" (some clients always send one).
void requireNoBody(const httplib::Request& req) {
  if (req.body.empty()) return;
  nlohmann::json body = nlohmann::json::parse(req.body, nullptr, false);
  if (!body.is_object() || !body.empty()) {
    throw ProblemError(invalidBody("", "This request takes no body (or an empty object {})."));
  }
}

// "/v1/sessions/{id}/materials/{mid}": the material index, 404 when there is none.
uint32_t materialIndex(const Session& session, const std::string& text) {
  uint32_t index = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), index);
  if (ec != std::errc() || end != text.data() + text.size() || index >= session.materials.size()) {
    throw ProblemError(notFoundDetail("The session's model has no material " +
                                      quoteClientText(text) + " (it has " +
                                      std::to_string(session.materials.size()) + ", ids from 0)."));
  }
  return index;
}

void getCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->camera));
}

// PUT (whole camera) and PATCH (any subset): both must leave a valid camera.
void setCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res,
               bool patch) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  nlohmann::json body =
      jsonBody(req, patch ? protocol::schema_names::kCameraPatch : protocol::schema_names::kCamera);
  auto lock = lockOpen(*session);
  protocol::Camera camera = patch ? protocol::applied(toWire(session->camera),
                                                      body.get<protocol::CameraPatch>())
                                  : body.get<protocol::Camera>();
  throwIfInvalid(protocol::checkCamera(camera));
  session->camera = fromWire(camera);
  session->bump();
  sendJson(res, toWire(session->camera));
}

void frameCamera(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  requireNoBody(req);
  auto lock = lockOpen(*session);
  // Keeps the direction the user looks from and the field of view; moves the eye so the whole
  // model fits.
  const scene::Camera& current = session->camera;
  session->camera = scene::frameBounds(session->model.bounds, current.eye - current.target,
                                       current.fovYDegrees, kFramingAspect);
  session->bump();
  sendJson(res, toWire(session->camera));
}

void getSettings(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->settings));
}

void patchSettings(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto patch =
      jsonBody(req, protocol::schema_names::kSettingsPatch).get<protocol::SettingsPatch>();
  if (patch.sun && patch.sun->direction) throwIfInvalid(protocol::checkSunDirection(*patch.sun->direction));
  auto lock = lockOpen(*session);
  const bool wasAnimating = session->settings.animate;
  session->settings = fromWire(protocol::applied(toWire(session->settings), patch));
  // Animation time restarts when animation is switched on, so lights start from where they are.
  if (session->settings.animate && !wasAnimating) session->animationStart = Clock::now();
  session->bump();
  sendJson(res, toWire(session->settings));
}

void getMaterials(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  protocol::MaterialsList list;
  list.materials.reserve(session->materials.size());
  for (uint32_t i = 0; i < session->materials.size(); ++i) {
    list.materials.push_back(toWire(i, session->materials[i]));
  }
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
    const uint32_t index = materialIndex(*session, req.matches[2].str());
    result = protocol::applied(toWire(index, session->materials[index]), patch);
    scene::Material& material = session->materials[index];
    material.baseColor = fromWire(result.baseColor);
    material.metallic = float(result.metallic);
    material.roughness = float(result.roughness);
    uploaded = context.renderThread.updateMaterials(
        session->sceneId, {render::MaterialWrite{index, material}});
    session->bump();
  }
  uploaded.get();
  sendJson(res, result);
}

}  // namespace

void addSceneRoutes(Routes& routes, ApiContext& context) {
  auto bind = [&context](void (*handler)(ApiContext&, const httplib::Request&,
                                         httplib::Response&)) {
    return [&context, handler](const httplib::Request& req, httplib::Response& res) {
      handler(context, req, res);
    };
  };
  routes.add("GET", "/v1/sessions/{id}/camera", bind(getCamera));
  routes.add("PUT", "/v1/sessions/{id}/camera",
             [&context](const httplib::Request& req, httplib::Response& res) {
               setCamera(context, req, res, false);
             });
  routes.add("PATCH", "/v1/sessions/{id}/camera",
             [&context](const httplib::Request& req, httplib::Response& res) {
               setCamera(context, req, res, true);
             });
  routes.add("POST", "/v1/sessions/{id}/camera/frame", bind(frameCamera));
  routes.add("GET", "/v1/sessions/{id}/settings", bind(getSettings));
  routes.add("PATCH", "/v1/sessions/{id}/settings", bind(patchSettings));
  routes.add("GET", "/v1/sessions/{id}/materials", bind(getMaterials));
  routes.add("PATCH", "/v1/sessions/{id}/materials/{mid}", bind(patchMaterial));
}

}  // namespace myriad::service
