// A session's local lights: parse, authorize, one SessionScene edit, queue its GPU change (under
// the session's lock, so the render thread sees edits in the order the CPU copy took them), answer.
#include <charconv>
#include <cmath>
#include <optional>

#include "protocol/constants.h"
#include "protocol/types.h"
#include "protocol/validate.h"
#include "scene/light_generator.h"
#include "service/api.h"
#include "render/marker_pick.h"
#include "render/render_queue.h"
#include "service/session_json.h"
#include "service/startup.h"

namespace myriad::service {
namespace {

constexpr uint64_t kDefaultPageSize = 100;
constexpr uint64_t kMaxPageSize = 1000;

// Queues `update` on the session's GPU scene and records the change (session locked).
std::future<void> queue(ApiContext& context, Session& session, render::LightUpdate update) {
  std::future<void> uploaded = context.renderThread.updateLights(session.sceneId, std::move(update));
  session.bump();
  return uploaded;
}

void getPage(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const uint64_t offset = unsignedParameter(req, "offset", 0, 0, UINT32_MAX);
  const uint64_t limit = unsignedParameter(req, "limit", kDefaultPageSize, 0, kMaxPageSize);
  auto lock = lockOpen(*session);
  const SessionScene& scene = session->scene;
  protocol::LightsPage page;
  page.total = scene.lightCount();
  page.offset = offset;
  for (uint64_t i = offset; i < scene.lightCount() && i < offset + limit; ++i) {
    page.lights.push_back(toWire(scene.idAt(uint32_t(i)), scene.lightAt(uint32_t(i))));
  }
  sendJson(res, page);
}

void addLights(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto body = jsonBody(req, protocol::schema_names::kLightsAdd).get<protocol::LightsAdd>();
  std::vector<scene::PointLight> lights;
  lights.reserve(body.lights.size());
  for (size_t i = 0; i < body.lights.size(); ++i) {
    lights.push_back(fromWire(body.lights[i], "/lights/" + std::to_string(i)));
  }

  protocol::LightsAdded added;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    uploaded = queue(context, *session, session->scene.addLights(lights, &added.ids));
    added.total = session->scene.lightCount();
  }
  uploaded.get();
  sendJson(res, added, 201);
}

void clearLights(ApiContext& context, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    uploaded = queue(context, *session, session->scene.clearLights());
  }
  uploaded.get();
  res.status = 204;
}

void getLight(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  const uint32_t slot = session->scene.slotOf(req.matches[2].str());
  sendJson(res, toWire(session->scene.idAt(slot), session->scene.lightAt(slot)));
}

void patchLight(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto patch = jsonBody(req, protocol::schema_names::kLightPatch).get<protocol::LightPatch>();
  protocol::Light result;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    SessionScene& scene = session->scene;
    const uint32_t slot = scene.slotOf(req.matches[2].str());
    uploaded = queue(context, *session, scene.patchLight(slot, patch));
    result = toWire(scene.idAt(slot), scene.lightAt(slot));
  }
  uploaded.get();
  sendJson(res, result);
}

void deleteLight(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    const uint32_t slot = session->scene.slotOf(req.matches[2].str());
    uploaded = queue(context, *session, session->scene.removeLight(slot));
  }
  uploaded.get();
  res.status = 204;
}

void generate(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto request =
      jsonBody(req, protocol::schema_names::kLightsGenerate).get<protocol::LightsGenerate>();
  if (auto error = protocol::checkLightsGenerate(request)) {
    throw ProblemError(invalidBody(error->pointer, error->message));
  }
  scene::Bounds modelBounds;
  std::string modelSource;
  {
    auto lock = lockOpen(*session);
    // Checked before generating, so an absurd count costs nothing.
    session->scene.checkLightTotal(request.count, "This would leave the session with " +
                                                      std::to_string(request.count) + " lights");
    modelBounds = session->scene.model().bounds;
    modelSource = session->scene.model().source;
  }
  scene::LightGeneration generation =
      defaultLightGeneration(modelSource, modelBounds, uint32_t(request.count), request.seed);
  if (request.bounds) generation.bounds = fromWire(*request.bounds);
  if (request.radius) {
    generation.minRadius = float(request.radius->min);
    generation.maxRadius = float(request.radius->max);
  }
  if (request.intensity) {
    generation.minIntensity = float(request.intensity->min);
    generation.maxIntensity = float(request.intensity->max);
  }
  if (request.falloff) generation.falloff = float(*request.falloff);
  // Generated outside the lock: a million lights take a moment, and hundreds of megabytes on
  // their way to the GPU (held until the upload is done).
  const MemoryBudget::Reservation memory =
      reserveMemory(context, request.count * memory_cost::kGeneratedLightBytes,
                    std::to_string(request.count) + " generated lights");
  const std::vector<scene::PointLight> lights = scene::generateLights(generation);

  protocol::LightsGenerated generated;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    SessionScene& scene = session->scene;
    // Generated with the defaults (around the model), they are refitted when a model is loaded.
    const bool defaults = !request.bounds && !request.radius && !request.intensity && !request.falloff;
    std::optional<LightRecipe> recipe;
    if (defaults) recipe = LightRecipe{uint32_t(request.count), request.seed};
    uploaded = queue(context, *session,
                     request.replaces() ? scene.replaceLights(lights, recipe) : scene.addLights(lights));
    generated.total = scene.lightCount();
  }
  uploaded.get();
  sendJson(res, generated);
}

// A finite number in [min, max] from the query, or 400 naming the parameter.
double numberParameter(const httplib::Request& req, const std::string& name, double min,
                       double max, std::optional<double> fallback = std::nullopt) {
  if (!req.has_param(name)) {
    if (fallback) return *fallback;
    throw ProblemError(invalidParameter(name, "\"" + name + "\" is required."));
  }
  const std::string text = req.get_param_value(name);
  double value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() ||
      !std::isfinite(value) || value < min || value > max) {
    throw ProblemError(invalidParameter(
        name, "\"" + name + "\" must be a number from " + std::to_string(int64_t(min)) + " to " +
                  std::to_string(int64_t(max)) + ", not " + quoteClientText(text) + "."));
  }
  return value;
}

// GET .../lights/pick?x=&y=&width=&height=[&radius=]: the light whose marker is under the pixel,
// found among all the session's lights (render/marker_pick.h), answered by id.
void pick(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  constexpr uint64_t kMaxSide = 16384;
  for (const char* required : {"width", "height"}) {
    if (!req.has_param(required)) {
      throw ProblemError(invalidParameter(
          required, "\"" + std::string(required) +
                        "\" is required: the size in pixels of the frame the pixel is in."));
    }
  }
  const uint64_t width = unsignedParameter(req, "width", 0, 1, kMaxSide);
  const uint64_t height = unsignedParameter(req, "height", 0, 1, kMaxSide);
  const double x = numberParameter(req, "x", 0, double(width));
  const double y = numberParameter(req, "y", 0, double(height));
  if (x >= double(width) || y >= double(height)) {
    throw ProblemError(invalidParameter(x >= double(width) ? "x" : "y",
                                        "The pixel must lie inside the width x height frame."));
  }
  const float radius = float(numberParameter(req, "radius", 0, 64, 0.0));
  protocol::LightPick answer;
  auto lock = lockOpen(*session);
  const SessionScene& scene = session->scene;
  const std::optional<render::MarkerHit> hit =
      render::pickMarker(scene.lights(), scene.camera(), uint32_t(width), uint32_t(height), x, y,
                         radius);
  if (hit) {
    answer.light = toWire(scene.idAt(hit->slot), scene.lightAt(hit->slot));
    answer.distance = hit->distance;
    answer.candidates = hit->candidates;
  }
  sendJson(res, answer);
}

}  // namespace

void addLightRoutes(Routes& routes, ApiContext& context) {
  auto bind = [&context](ContextHandler handler) { return bindContext(context, handler); };
  routes.add("GET", protocol::routes::kSessionLights, bind(getPage));
  routes.add("POST", protocol::routes::kSessionLights, bind(addLights));
  routes.add("DELETE", protocol::routes::kSessionLights, bind(clearLights));
  // Before {lid}, which would otherwise take "generate" or "pick" for a light id.
  routes.add("POST", protocol::routes::kSessionLightsGenerate, bind(generate));
  routes.add("GET", protocol::routes::kSessionLightsPick, bind(pick));
  routes.add("GET", protocol::routes::kSessionLight, bind(getLight));
  routes.add("PATCH", protocol::routes::kSessionLight, bind(patchLight));
  routes.add("DELETE", protocol::routes::kSessionLight, bind(deleteLight));
}

}  // namespace myriad::service
