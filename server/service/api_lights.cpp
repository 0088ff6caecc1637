// A session's local lights. The CPU copy (Session::lights, ids, index) changes first, under the
// session's lock, and the same lock covers handing the render thread only what changed: appended
// lights, one patched light, a swap-remove (the last light moves into the hole), or a new count.
#include <charconv>

#include "protocol/constants.h"
#include "protocol/types.h"
#include "protocol/validate.h"
#include "scene/light_generator.h"
#include "service/api.h"
#include "service/render_thread.h"
#include "service/session_json.h"
#include "service/startup.h"

namespace myriad::service {
namespace {

constexpr uint64_t kDefaultPageSize = 100;
constexpr uint64_t kMaxPageSize = 1000;

uint64_t unsignedParameter(const httplib::Request& req, const std::string& name, uint64_t fallback,
                           uint64_t min, uint64_t max) {
  if (!req.has_param(name)) return fallback;
  const std::string text = req.get_param_value(name);
  uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < min ||
      value > max) {
    throw ProblemError(invalidParameter(name, "\"" + name + "\" must be an integer from " +
                                                  std::to_string(min) + " to " +
                                                  std::to_string(max) + ", not " +
                                                  quoteClientText(text) + "."));
  }
  return value;
}

// The index of light `text` (a route segment) in the session, 404 when there is none.
uint32_t lightIndex(const Session& session, const std::string& text) {
  uint64_t id = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  auto it = session.lightIndex.end();
  if (ec == std::errc() && end == text.data() + text.size()) it = session.lightIndex.find(id);
  if (it == session.lightIndex.end()) {
    throw ProblemError(notFoundDetail("The session has no light " + quoteClientText(text) +
                                      " (deleted, or never created)."));
  }
  return it->second;
}

void checkTotal(const ApiContext& context, uint64_t total) {
  const uint32_t limit = context.config.limits.maxLightsPerSession;
  if (total > limit) {
    throw ProblemError(limitExceeded(
        413, "maxLightsPerSession",
        "This would leave the session with " + std::to_string(total) +
            " lights; a session holds at most " + std::to_string(limit) + "."));
  }
}

// Appends `lights` with fresh ids (session locked); returns the update that uploads them.
render::LightUpdate append(Session& session, const std::vector<scene::PointLight>& lights,
                           std::vector<uint64_t>* ids) {
  render::LightUpdate update;
  const uint32_t first = uint32_t(session.lights.size());
  update.count = first + uint32_t(lights.size());
  update.writes.reserve(lights.size());
  session.lights.reserve(update.count);
  session.lightIds.reserve(update.count);
  for (uint32_t i = 0; i < lights.size(); ++i) {
    const uint64_t id = session.nextLightId++;
    session.lights.push_back(lights[i]);
    session.lightIds.push_back(id);
    session.lightIndex.emplace(id, first + i);
    update.writes.push_back(render::LightWrite{first + i, lights[i]});
    if (ids != nullptr) ids->push_back(id);
  }
  return update;
}

void clear(Session& session) {
  session.lights.clear();
  session.lightIds.clear();
  session.lightIndex.clear();
}

void getPage(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {"offset", "limit"});
  const uint64_t offset = unsignedParameter(req, "offset", 0, 0, UINT32_MAX);
  const uint64_t limit = unsignedParameter(req, "limit", kDefaultPageSize, 0, kMaxPageSize);
  auto lock = lockOpen(*session);
  protocol::LightsPage page;
  page.total = session->lights.size();
  page.offset = offset;
  for (uint64_t i = offset; i < session->lights.size() && i < offset + limit; ++i) {
    page.lights.push_back(toWire(session->lightIds[i], session->lights[i]));
  }
  sendJson(res, page);
}

void addLights(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto body = jsonBody(req, protocol::schema_names::kLightsAdd).get<protocol::LightsAdd>();
  std::vector<scene::PointLight> lights;
  lights.reserve(body.lights.size());
  for (const protocol::LightNew& light : body.lights) lights.push_back(fromWire(light));

  protocol::LightsAdded added;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    checkTotal(context, session->lights.size() + lights.size());
    render::LightUpdate update = append(*session, lights, &added.ids);
    added.total = session->lights.size();
    uploaded = context.renderThread.updateLights(session->sceneId, std::move(update));
    session->bump();
  }
  uploaded.get();
  sendJson(res, added, 201);
}

void clearLights(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    clear(*session);
    uploaded = context.renderThread.updateLights(session->sceneId, render::LightUpdate{});
    session->bump();
  }
  uploaded.get();
  res.status = 204;
}

void getLight(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  const uint32_t index = lightIndex(*session, req.matches[2].str());
  sendJson(res, toWire(session->lightIds[index], session->lights[index]));
}

void patchLight(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto patch = jsonBody(req, protocol::schema_names::kLightPatch).get<protocol::LightPatch>();
  protocol::Light result;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    const uint32_t index = lightIndex(*session, req.matches[2].str());
    result = protocol::applied(toWire(session->lightIds[index], session->lights[index]), patch);
    session->lights[index] = fromWire(result);
    render::LightUpdate update;
    update.count = uint32_t(session->lights.size());
    update.writes.push_back(render::LightWrite{index, session->lights[index]});
    uploaded = context.renderThread.updateLights(session->sceneId, std::move(update));
    session->bump();
  }
  uploaded.get();
  sendJson(res, result);
}

void deleteLight(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    const uint32_t index = lightIndex(*session, req.matches[2].str());
    const uint32_t last = uint32_t(session->lights.size() - 1);
    render::LightUpdate update;
    update.count = last;
    session->lightIndex.erase(session->lightIds[index]);
    if (index != last) {
      session->lights[index] = session->lights[last];
      session->lightIds[index] = session->lightIds[last];
      session->lightIndex[session->lightIds[index]] = index;
      update.writes.push_back(render::LightWrite{index, session->lights[index]});
    }
    session->lights.pop_back();
    session->lightIds.pop_back();
    uploaded = context.renderThread.updateLights(session->sceneId, std::move(update));
    session->bump();
  }
  uploaded.get();
  res.status = 204;
}

void generate(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const auto request =
      jsonBody(req, protocol::schema_names::kLightsGenerate).get<protocol::LightsGenerate>();
  if (auto error = protocol::checkLightsGenerate(request)) {
    throw ProblemError(invalidBody(error->pointer, error->message));
  }
  // Checked before generating, so an absurd count costs nothing.
  checkTotal(context, request.count);

  scene::Bounds modelBounds;
  {
    auto lock = lockOpen(*session);
    modelBounds = session->model.bounds;
  }
  scene::LightGeneration generation =
      lightGenerationAround(modelBounds, uint32_t(request.count), request.seed);
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
  // Generated outside the lock: a million lights take a moment.
  const std::vector<scene::PointLight> lights = scene::generateLights(generation);

  protocol::LightsGenerated generated;
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    if (request.replaces()) {
      clear(*session);
    } else {
      checkTotal(context, session->lights.size() + lights.size());
    }
    render::LightUpdate update = append(*session, lights, nullptr);
    generated.total = session->lights.size();
    uploaded = context.renderThread.updateLights(session->sceneId, std::move(update));
    session->bump();
  }
  uploaded.get();
  sendJson(res, generated);
}

}  // namespace

void addLightRoutes(Routes& routes, ApiContext& context) {
  auto bind = [&context](void (*handler)(ApiContext&, const httplib::Request&,
                                         httplib::Response&)) {
    return [&context, handler](const httplib::Request& req, httplib::Response& res) {
      handler(context, req, res);
    };
  };
  routes.add("GET", "/v1/sessions/{id}/lights", bind(getPage));
  routes.add("POST", "/v1/sessions/{id}/lights", bind(addLights));
  routes.add("DELETE", "/v1/sessions/{id}/lights", bind(clearLights));
  // Before {lid}, which would otherwise take "generate" for a light id.
  routes.add("POST", "/v1/sessions/{id}/lights/generate", bind(generate));
  routes.add("GET", "/v1/sessions/{id}/lights/{lid}", bind(getLight));
  routes.add("PATCH", "/v1/sessions/{id}/lights/{lid}", bind(patchLight));
  routes.add("DELETE", "/v1/sessions/{id}/lights/{lid}", bind(deleteLight));
}

}  // namespace myriad::service
