// A session's scene as assets and objects (service/scene_graph.h): upload, list, inspect and
// delete assets; add, list, read, patch and delete objects. Each edit is one SessionScene call
// under the session's lock, whose GPU change (a whole scene, or a move of some instances) is
// queued before the lock is released, so a frame requested after the answer shows it.
#include <algorithm>
#include <cmath>
#include <map>

#include "protocol/constants.h"
#include "render/render_queue.h"
#include "scene/animation.h"
#include "service/api.h"
#include "service/session_json.h"

namespace myriad::service {
namespace {

// Queues a scene change on the session's GPU scene (under its lock).
std::future<void> queue(ApiContext& context, const Session& session, SceneChange change) {
  if (change.moved) return context.renderThread.updateInstances(session.sceneId, std::move(*change.moved));
  if (change.scene) return context.renderThread.replaceScene(session.sceneId, std::move(change.scene));
  std::promise<void> none;
  none.set_value();
  return none.get_future();
}

// An animation clip asked for by name (animation.clipName, which wins over clip): its index in
// the object's asset (400 naming `pointer`/animation/clipName when the asset has none of that
// name). By index or null, applyObjectPatch already set it.
void resolveClip(const protocol::ObjectPatch& patch, const SceneGraph& graph, SceneObject& o,
                 const std::string& pointer) {
  if (!patch.animation || !patch.animation->clipName) return;
  const std::string& name = *patch.animation->clipName;
  const Asset* asset = graph.findAsset(o.asset);
  if (asset == nullptr) return;  // SceneGraph's checks name the missing asset
  const int clip = scene::findClip(*asset->scene, name);
  if (clip < 0) {
    throw ProblemError(invalidBody(pointer + "/animation/clipName",
                                   "Asset " + quoteClientText(o.asset) + " has no animation clip " +
                                       quoteClientText(name) + " (it has " +
                                       std::to_string(asset->scene->animations.size()) + ")."));
  }
  o.clip = clip;
}

// A node asked for by name (nodeName, which wins over node): the first node of that name in the
// object's asset (400 naming `pointer`/nodeName when there is none).
void resolveNode(const protocol::ObjectPatch& patch, const SceneGraph& graph, SceneObject& o,
                 const std::string& pointer) {
  if (!patch.nodeName) return;
  const Asset* asset = graph.findAsset(o.asset);
  if (asset == nullptr) return;
  const auto& nodes = asset->scene->nodes;
  const auto it = std::find_if(nodes.begin(), nodes.end(),
                               [&](const scene::Node& n) { return n.name == *patch.nodeName; });
  if (it == nodes.end()) {
    throw ProblemError(invalidBody(pointer + "/nodeName",
                                   "Asset " + quoteClientText(o.asset) + " has no node named " +
                                       quoteClientText(*patch.nodeName) + "."));
  }
  o.node = int32_t(it - nodes.begin());
}

// An item asked as its asset's node tree (`tree`: true): the tree's objects from `firstId` on
// (nodeTreeObjects, as PUT .../model makes them), the item's own members on the root node's
// object (its transform on top of the root node's own), its class, material and clip on every
// one. Any other item is itself.
std::vector<SceneObject> treeOf(const protocol::ObjectPatch& item, SceneObject o,
                                const SceneGraph& graph, uint32_t firstId, size_t pending,
                                const std::string& pointer) {
  if (!item.tree.value_or(false)) return {std::move(o)};
  if (o.node >= 0) {
    throw ProblemError(invalidBody(pointer + "/tree",
                                   "tree makes objects of the whole asset's node tree: it is not "
                                   "given with node or nodeName."));
  }
  const Asset* asset = graph.findAsset(o.asset);
  if (asset == nullptr) return {std::move(o)};  // SceneGraph::addObjects names the asset
  const size_t used = graph.objects().size() + pending;
  const size_t room = graph.maxObjects() > used ? graph.maxObjects() - used : 0;
  std::vector<SceneObject> tree = nodeTreeObjects(*asset, firstId, o.name, room);
  if (tree.empty()) {
    throw ProblemError(invalidBody(
        pointer + "/tree",
        "Asset " + quoteClientText(o.asset) + " (" + std::to_string(asset->scene->nodes.size()) +
            " nodes) makes no node tree of objects: that needs at least two nodes with meshes, "
            "no skins, and no more nodes than the " + std::to_string(room) +
            " objects the session has room for."));
  }
  SceneObject& root = tree.front();
  const glm::mat4 own = root.transform.local();
  const glm::mat4 asked = o.transform.local();
  if (asked != glm::mat4(1.0f)) {
    if (own == glm::mat4(1.0f)) {
      root.transform = o.transform;
    } else {
      root.transform = ObjectTransform{};
      root.transform.matrix = asked * own;
    }
  }
  root.parent = o.parent;
  root.visible = o.visible;
  for (SceneObject& part : tree) {
    part.material = o.material;
    part.semantic = o.semantic;
    part.semanticClass = o.semanticClass;
    part.clip = o.clip;
    part.loop = o.loop;
  }
  return tree;
}

// A problem SceneGraph::addObjects blamed on `/objects/N...`, N counting placed objects, told of
// the request's item N came from (a tree item places several).
Problem renumberedItem(Problem problem, const std::vector<size_t>& itemOf) {
  constexpr std::string_view kPrefix = "/objects/";
  if (!problem.pointer || !problem.pointer->starts_with(kPrefix)) return problem;
  const std::string& pointer = *problem.pointer;
  size_t end = kPrefix.size();
  while (end < pointer.size() && pointer[end] >= '0' && pointer[end] <= '9') ++end;
  if (end == kPrefix.size() || end - kPrefix.size() > 9) return problem;
  const size_t placed = std::stoul(pointer.substr(kPrefix.size(), end - kPrefix.size()));
  if (placed >= itemOf.size()) return problem;
  problem.pointer = std::string(kPrefix) + std::to_string(itemOf[placed]) + pointer.substr(end);
  return problem;
}

// The 201 answer of a request that added objects (objects-added): their ids, in the order added,
// and how many objects the session has now.
void sendAdded(httplib::Response& res, const std::vector<uint32_t>& ids, size_t total) {
  protocol::ObjectsAdded added;
  added.ids.assign(ids.begin(), ids.end());
  added.total = total;
  sendJson(res, added, 201);
}

// ---- Assets.

void listAssets(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  protocol::AssetsList list;
  for (const Asset& a : graph.assets()) list.assets.push_back(toWire(graph, a));
  sendJson(res, list);
}

void addAsset(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  // Loading takes from milliseconds to the loader's time limit; the session stays usable.
  LoadedModel model = loadModelRequest(context, req);
  std::future<void> uploaded;
  protocol::Asset answer;
  bool added = false;
  {
    auto lock = lockOpen(*session);
    SessionScene::AssetAdded result = session->scene.addAsset(
        std::move(model.scene), model.source, model.assetId, model.bytes);
    added = result.added;
    // With --state-dir: the bytes kept, so that a restored session has the asset again.
    if (model.stored) session->persisted.assets.insert_or_assign(model.assetId, *model.stored);
    if (result.scene) {
      uploaded = context.renderThread.replaceScene(session->sceneId, std::move(result.scene));
      session->bump();
    }
    answer = toWire(session->scene.graph(), *result.asset);
  }
  if (uploaded.valid()) uploaded.get();
  res.set_header(std::string(protocol::headers::kLocation),
                 protocol::expandRoute(protocol::expandRoute(protocol::routes::kSessionAsset, "id",
                                                             session->id),
                                       "aid", answer.id));
  sendJson(res, answer, added ? 201 : 200);
}

void getAsset(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  sendJson(res, toWire(graph, graph.asset(req.matches[2].str())));
}

void deleteAsset(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
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

void listObjects(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const uint64_t offset = unsignedParameter(req, "offset", 0, 0, UINT32_MAX);
  const uint64_t limit = unsignedParameter(req, "limit", protocol::query::kDefaultObjectsPageLimit,
                                           0, protocol::query::kMaxObjectsPageLimit);
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  const auto& objects = graph.objects();
  protocol::ObjectsPage page;
  page.total = objects.size();
  page.offset = offset;
  page.nextObjectId = graph.nextObjectId();
  auto it = objects.begin();
  std::advance(it, std::min<uint64_t>(offset, objects.size()));
  for (uint64_t n = 0; it != objects.end() && n < limit; ++it, ++n) {
    page.objects.push_back(toWire(session->scene, it->second));
  }
  sendJson(res, page);
}

void addObjects(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto body =
      jsonBody(req, protocol::schema_names::kObjectsAdd).get<protocol::ObjectsAdd>();
  std::vector<SceneObject> objects;
  objects.reserve(body.objects.size());
  for (size_t i = 0; i < body.objects.size(); ++i) {
    SceneObject o;
    try {
      applyObjectPatch(body.objects[i], o);
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
    for (size_t i = 0; i < objects.size(); ++i) {
      resolveNode(body.objects[i], session->scene.graph(), objects[i],
                  "/objects/" + std::to_string(i));
      resolveClip(body.objects[i], session->scene.graph(), objects[i],
                  "/objects/" + std::to_string(i));
    }
    for (SceneObject& o : objects) {
      if (o.name.empty()) {
        const Asset* a = session->scene.graph().findAsset(o.asset);
        if (a != nullptr) o.name = a->source;
      }
    }
    std::vector<SceneObject> placed;
    std::vector<size_t> itemOf;  // placed object -> the request's item it came from
    placed.reserve(objects.size());
    for (size_t i = 0; i < objects.size(); ++i) {
      const SceneGraph& graph = session->scene.graph();
      for (SceneObject& o : treeOf(body.objects[i], std::move(objects[i]), graph,
                                   graph.nextObjectId() + uint32_t(placed.size()), placed.size(),
                                   "/objects/" + std::to_string(i))) {
        placed.push_back(std::move(o));
        itemOf.push_back(i);
      }
    }
    std::shared_ptr<const scene::Scene> scene;
    try {
      scene = session->scene.addObjects(std::move(placed), &ids);
    } catch (const ProblemError& e) {
      throw ProblemError(renumberedItem(e.problem(), itemOf));
    }
    uploaded = context.renderThread.replaceScene(session->sceneId, std::move(scene));
    total = session->scene.graph().objects().size();
    session->bump();
  }
  uploaded.get();
  sendAdded(res, ids, total);
}

void getObject(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  const SceneGraph& graph = session->scene.graph();
  sendJson(res, toWire(session->scene, graph.object(graph.objectId(req.matches[2].str()))));
}

void patchObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto patch =
      jsonBody(req, protocol::schema_names::kObjectPatch).get<protocol::ObjectPatch>();
  std::future<void> uploaded;
  protocol::Object answer;
  {
    auto lock = lockOpen(*session);
    const SceneGraph& graph = session->scene.graph();
    SceneObject next = graph.object(graph.objectId(req.matches[2].str()));
    applyObjectPatch(patch, next);
    resolveNode(patch, graph, next, "");
    resolveClip(patch, graph, next, "");
    uploaded = queue(context, *session, session->scene.replaceObject(next));
    session->bump();
    answer = toWire(session->scene, graph.object(next.id));
  }
  uploaded.get();
  sendJson(res, answer);
}

// POST .../objects/{oid}/duplicate's body (object-duplicate.schema.json), read only here.
struct ObjectDuplicate {
  std::optional<std::string> name;
  std::optional<protocol::Transform> transform;
  std::optional<protocol::Nullable<uint64_t>> parent;
  std::optional<bool> children;
};
template <class F>
void members(protocol::Tag<ObjectDuplicate>, F f) {
  f("name", &ObjectDuplicate::name);
  f("transform", &ObjectDuplicate::transform);
  f("parent", &ObjectDuplicate::parent);
  f("children", &ObjectDuplicate::children);
}
MYRIAD_PROTOCOL_MEMBERWISE(ObjectDuplicate)

// Copies of the object and (children) the objects below it, parents first, each copy's parent
// the copy of its object's parent; the first is the object's copy, with what the body changes.
std::vector<SceneObject> copiesOf(const SceneGraph& graph, uint32_t original,
                                  const ObjectDuplicate& body) {
  const std::vector<uint32_t> sources =
      body.children.value_or(true) ? graph.subtree(original) : std::vector<uint32_t>{original};
  constexpr size_t kMostCopies = 10000;  // objects-added.schema.json's ids, as POST .../objects
  if (sources.size() > kMostCopies) {
    throw ProblemError(invalidBody(
        "/children", "The object and those below it are " + std::to_string(sources.size()) +
                         " objects; one duplicate copies at most " + std::to_string(kMostCopies) +
                         " (children false copies the object alone)."));
  }
  std::map<uint32_t, uint32_t> copyOf;  // an object -> the id its copy gets
  std::vector<SceneObject> copies;
  copies.reserve(sources.size());
  for (uint32_t source : sources) {
    SceneObject copy = graph.object(source);
    copyOf.emplace(source, graph.nextObjectId() + uint32_t(copies.size()));
    if (source != original) copy.parent = copyOf.at(copy.parent);
    copies.push_back(std::move(copy));
  }
  SceneObject& root = copies.front();
  if (body.name) root.name = *body.name;
  if (body.transform) root.transform = fromWire(*body.transform);
  // Under the object itself or one below it is fine: the copy is a new object, no cycle.
  if (body.parent) root.parent = uint32_t(body.parent->value.value_or(0));
  return copies;
}

void duplicateObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto body = jsonBody(req).get<ObjectDuplicate>();
  std::vector<uint32_t> ids;
  std::future<void> uploaded;
  size_t total = 0;
  {
    auto lock = lockOpen(*session);
    const SceneGraph& graph = session->scene.graph();
    std::vector<SceneObject> copies =
        copiesOf(graph, graph.objectId(req.matches[2].str()), body);
    std::shared_ptr<const scene::Scene> scene;
    try {
      scene = session->scene.addObjects(std::move(copies), &ids);
    } catch (const ProblemError& e) {
      // SessionScene::addObjects names /objects/N/...: the body's member for the first copy.
      Problem problem = e.problem();
      if (problem.pointer && problem.pointer->starts_with("/objects/0/")) {
        problem.pointer = problem.pointer->substr(std::string_view("/objects/0").size());
      }
      throw ProblemError(problem);
    }
    uploaded = context.renderThread.replaceScene(session->sceneId, std::move(scene));
    total = session->scene.graph().objects().size();
    session->bump();
  }
  uploaded.get();
  sendAdded(res, ids, total);
}

void deleteObject(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
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

// ---- The scene clock.

protocol::Clock toWire(const SessionScene::SceneClock& c) {
  return {c.time, c.playing, c.rate, c.duration};
}

void getClock(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  auto lock = lockOpen(*session);
  sendJson(res, toWire(session->scene.clock(Clock::now())));
}

void patchClock(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto patch = jsonBody(req, protocol::schema_names::kClockPatch).get<protocol::ClockPatch>();
  protocol::Clock answer;
  {
    auto lock = lockOpen(*session);
    answer = toWire(session->scene.patchClock(patch.playing, patch.time, patch.rate, Clock::now()));
    // Streams and shared pages see the change as any other edit (a paused clock stops them).
    session->bump();
  }
  sendJson(res, answer);
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
  routes.add("duplicateObject", bind(duplicateObject));
  routes.add("GET", protocol::routes::kSessionClock, bind(getClock));
  routes.add("PATCH", protocol::routes::kSessionClock, bind(patchClock));
}

}  // namespace myriad::service
