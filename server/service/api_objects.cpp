// A session's scene as assets and objects (service/scene_graph.h): upload, list, inspect and
// delete assets; add, list, read, patch and delete objects. Each edit is one SessionScene call
// under the session's lock, whose GPU change (a whole scene, or a move of some instances) is
// queued before the lock is released, so a frame requested after the answer shows it.
#include <algorithm>
#include <cmath>

#include "protocol/constants.h"
#include "render/render_queue.h"
#include "service/api.h"
#include "service/session_json.h"

namespace myriad::service {
namespace {

using nlohmann::json;

// ---- The wire form (the schemas have checked types and ranges).

json vec(const float* v, size_t n) {
  json out = json::array();
  for (size_t i = 0; i < n; ++i) out.push_back(v[i]);
  return out;
}

json boundsJson(const scene::Bounds& b) {
  return {{"min", vec(&b.min.x, 3)}, {"max", vec(&b.max.x, 3)}};
}

ObjectTransform transformFromWire(const json& j) {
  ObjectTransform t;
  const bool trs = j.contains("translation") || j.contains("rotation") || j.contains("scale");
  if (j.contains("matrix")) {
    if (trs) {
      throw ProblemError(invalidBody("/transform", "Give a transform as translation, rotation "
                                                   "and scale, or as a matrix, not both."));
    }
    glm::mat4 m(1.0f);
    const json& a = j["matrix"];
    for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = a[i].get<float>();
    t.matrix = m;
    return t;
  }
  if (j.contains("translation")) {
    const json& a = j["translation"];
    t.translation = glm::vec3(a[0].get<float>(), a[1].get<float>(), a[2].get<float>());
  }
  if (j.contains("rotation")) {
    const json& a = j["rotation"];
    // glTF's order x, y, z, w; glm's constructor takes w first.
    glm::quat q(a[3].get<float>(), a[0].get<float>(), a[1].get<float>(), a[2].get<float>());
    const float length = glm::length(q);
    if (!(length > 1e-6f) || !std::isfinite(length)) {
      throw ProblemError(invalidBody("/transform/rotation",
                                     "The rotation quaternion must not be [0, 0, 0, 0]."));
    }
    // A unit quaternion (as GET answers give it back) is kept as sent.
    t.rotation = std::abs(length - 1.0f) <= 1e-6f ? q : q / length;
  }
  if (j.contains("scale")) {
    const json& a = j["scale"];
    t.scale = glm::vec3(a[0].get<float>(), a[1].get<float>(), a[2].get<float>());
  }
  return t;
}

json transformToWire(const ObjectTransform& t) {
  if (t.matrix) return {{"matrix", vec(&(*t.matrix)[0][0], 16)}};
  return {{"translation", vec(&t.translation.x, 3)},
          {"rotation", {t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w}},
          {"scale", vec(&t.scale.x, 3)}};
}

// The members of an object-new or object-patch body onto `o` (a patch: only those present).
void applyMembers(const json& j, SceneObject& o) {
  if (j.contains("name")) o.name = j["name"].get<std::string>();
  if (j.contains("asset")) o.asset = j["asset"].get<std::string>();
  if (j.contains("transform")) o.transform = transformFromWire(j["transform"]);
  if (j.contains("visible")) o.visible = j["visible"].get<bool>();
  if (j.contains("parent")) o.parent = j["parent"].is_null() ? 0 : j["parent"].get<uint32_t>();
  if (j.contains("material")) {
    o.material = j["material"].is_null() ? std::nullopt
                                          : std::optional<uint32_t>(j["material"].get<uint32_t>());
  }
  if (j.contains("semantic")) o.semantic = j["semantic"].get<uint32_t>();
}

json objectToWire(const SessionScene& scene, const SceneObject& o) {
  const SceneGraph& graph = scene.graph();
  json out = {{"id", o.id},
              {"name", o.name},
              {"asset", o.asset},
              {"transform", transformToWire(o.transform)},
              {"visible", o.visible},
              {"parent", o.parent == 0 ? json(nullptr) : json(o.parent)},
              {"material", o.material ? json(*o.material) : json(nullptr)},
              {"semantic", o.semantic}};
  const SceneGraph::Placement* placement = graph.placement(o.id);
  out["instances"] = placement != nullptr ? placement->count : 0;
  if (placement != nullptr && placement->count > 0) {
    // The world bounds of its instances, from the asset's bounds moved by its world transform.
    const Asset& asset = graph.asset(o.asset);
    if (!asset.bounds.empty()) {
      const glm::mat4 world = graph.worldOf(o.id);
      scene::Bounds b;
      for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 p((corner & 1) ? asset.bounds.max.x : asset.bounds.min.x,
                          (corner & 2) ? asset.bounds.max.y : asset.bounds.min.y,
                          (corner & 4) ? asset.bounds.max.z : asset.bounds.min.z);
        b.extend(glm::vec3(world * glm::vec4(p, 1.0f)));
      }
      out["bounds"] = boundsJson(b);
    }
  }
  return out;
}

json assetToWire(const SceneGraph& graph, const Asset& a) {
  json out = {{"id", a.id},
              {"source", a.source},
              {"bytes", a.bytes},
              {"meshes", a.scene->meshes.size()},
              {"instances", a.scene->instances.size()},
              {"materials", {{"first", a.firstMaterial}, {"count", a.scene->materials.size()}}},
              {"images", a.scene->images.size()},
              {"objects", graph.usersOf(a)}};
  if (!a.bounds.empty()) out["bounds"] = boundsJson(a.bounds);
  return out;
}

// Queues a scene change on the session's GPU scene (under its lock).
std::future<void> queue(ApiContext& context, const Session& session, SceneChange change) {
  if (change.moved) return context.renderThread.updateInstances(session.sceneId, std::move(*change.moved));
  if (change.scene) return context.renderThread.replaceScene(session.sceneId, std::move(change.scene));
  std::promise<void> none;
  none.set_value();
  return none.get_future();
}

// ---- Assets.

void listAssets(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  json list = json::array();
  for (const Asset& a : graph.assets()) list.push_back(assetToWire(graph, a));
  sendJson(res, json{{"assets", std::move(list)}});
}

void addAsset(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {"filename", "entry"});
  // Loading takes from milliseconds to the loader's time limit; the session stays usable.
  LoadedModel model = loadModelRequest(context, req);
  std::future<void> uploaded;
  json answer;
  bool added = false;
  {
    auto lock = lockOpen(*session);
    SessionScene::AssetAdded result = session->scene.addAsset(
        std::move(model.scene), model.source, model.assetId, model.bytes);
    added = result.added;
    if (result.scene) {
      uploaded = context.renderThread.replaceScene(session->sceneId, std::move(result.scene));
      session->bump();
    }
    answer = assetToWire(session->scene.graph(), *result.asset);
  }
  if (uploaded.valid()) uploaded.get();
  res.set_header(std::string(protocol::headers::kLocation),
                 protocol::expandRoute(protocol::expandRoute(protocol::routes::kSessionAsset, "id",
                                                             session->id),
                                       "aid", answer["id"].get<std::string>()));
  sendJson(res, answer, added ? 201 : 200);
}

void getAsset(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  sendJson(res, assetToWire(graph, graph.asset(req.matches[2].str())));
}

void deleteAsset(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    uploaded = context.renderThread.replaceScene(session->sceneId,
                                                 session->scene.removeAsset(req.matches[2].str()));
    session->bump();
  }
  uploaded.get();
  res.status = 204;
}

// ---- Objects.

void listObjects(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {"offset", "limit"});
  const uint64_t offset = unsignedParameter(req, "offset", 0, 0, UINT32_MAX);
  const uint64_t limit = unsignedParameter(req, "limit", protocol::query::kDefaultObjectsPageLimit,
                                           0, protocol::query::kMaxObjectsPageLimit);
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  const auto& objects = graph.objects();
  json page = json::array();
  auto it = objects.begin();
  std::advance(it, std::min<uint64_t>(offset, objects.size()));
  for (uint64_t n = 0; it != objects.end() && n < limit; ++it, ++n) {
    page.push_back(objectToWire(session->scene, it->second));
  }
  sendJson(res, json{{"total", objects.size()},
                     {"offset", offset},
                     {"nextObjectId", graph.nextObjectId()},
                     {"objects", std::move(page)}});
}

void addObjects(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const json body = jsonBody(req, protocol::schema_names::kObjectsAdd);
  std::vector<SceneObject> objects;
  objects.reserve(body["objects"].size());
  for (size_t i = 0; i < body["objects"].size(); ++i) {
    SceneObject o;
    try {
      applyMembers(body["objects"][i], o);
    } catch (const ProblemError& e) {
      throw ProblemError(invalidBody("/objects/" + std::to_string(i) +
                                         e.problem().pointer.value_or(""),
                                     e.problem().detail));
    }
    objects.push_back(std::move(o));
  }
  std::vector<uint32_t> ids;
  std::future<void> uploaded;
  size_t total = 0;
  {
    auto lock = lockOpen(*session);
    for (SceneObject& o : objects) {
      if (o.name.empty()) {
        const Asset* a = session->scene.graph().findAsset(o.asset);
        if (a != nullptr) o.name = a->source;
      }
    }
    uploaded = context.renderThread.replaceScene(
        session->sceneId, session->scene.addObjects(std::move(objects), &ids));
    total = session->scene.graph().objects().size();
    session->bump();
  }
  uploaded.get();
  sendJson(res, json{{"ids", ids}, {"total", total}}, 201);
}

void getObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  sendJson(res, objectToWire(session->scene, graph.object(graph.objectId(req.matches[2].str()))));
}

void patchObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  const json body = jsonBody(req, protocol::schema_names::kObjectPatch);
  std::future<void> uploaded;
  json answer;
  {
    auto lock = lockOpen(*session);
    const SceneGraph& graph = session->scene.graph();
    SceneObject next = graph.object(graph.objectId(req.matches[2].str()));
    applyMembers(body, next);
    uploaded = queue(context, *session, session->scene.replaceObject(next));
    session->bump();
    answer = objectToWire(session->scene, graph.object(next.id));
  }
  uploaded.get();
  sendJson(res, answer);
}

void deleteObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = authorizeSession(context, req);
  checkQuery(req, {});
  std::future<void> uploaded;
  {
    auto lock = lockOpen(*session);
    const uint32_t id = session->scene.graph().objectId(req.matches[2].str());
    uploaded = context.renderThread.replaceScene(session->sceneId, session->scene.removeObject(id));
    session->bump();
  }
  uploaded.get();
  res.status = 204;
}

}  // namespace

void addObjectRoutes(Routes& routes, ApiContext& context) {
  auto bind = [&context](ContextHandler handler) { return bindContext(context, handler); };
  RouteOptions upload;
  upload.maxBodyBytes = context.config.limits.maxUploadBytes;
  upload.bodyLimitName = "maxUploadBytes";
  routes.add("GET", protocol::routes::kSessionAssets, bind(listAssets));
  routes.add("POST", protocol::routes::kSessionAssets, bind(addAsset), upload);
  routes.add("GET", protocol::routes::kSessionAsset, bind(getAsset));
  routes.add("DELETE", protocol::routes::kSessionAsset, bind(deleteAsset));
  routes.add("GET", protocol::routes::kSessionObjects, bind(listObjects));
  routes.add("POST", protocol::routes::kSessionObjects, bind(addObjects));
  routes.add("GET", protocol::routes::kSessionObject, bind(getObject));
  routes.add("PATCH", protocol::routes::kSessionObject, bind(patchObject));
  routes.add("DELETE", protocol::routes::kSessionObject, bind(deleteObject));
}

}  // namespace myriad::service
