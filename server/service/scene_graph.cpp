#include "service/scene_graph.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>

#include <glm/gtc/matrix_transform.hpp>

#include "protocol/constants.h"
#include "scene/animation.h"
#include "service/problem.h"

namespace myriad::service {
namespace {

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

// A transform the renderer can use: finite, invertible (its normals need the inverse), and
// affine (a projective bottom row would bend the mesh's bounds).
bool usable(const glm::mat4& m) {
  if (!finite(m)) return false;
  if (m[0][3] != 0.0f || m[1][3] != 0.0f || m[2][3] != 0.0f || m[3][3] != 1.0f) return false;
  const float det = glm::determinant(glm::mat3(m));
  return std::isfinite(det) && std::abs(det) > 1e-30f;
}

// A node's rest world transform in its asset (its parents' local transforms times its own).
glm::mat4 restWorld(const scene::Scene& asset, int32_t node) {
  glm::mat4 rest(1.0f);
  for (int32_t n = node; n >= 0; n = asset.nodes[size_t(n)].parent) {
    rest = scene::localMatrix(asset.nodes[size_t(n)]) * rest;
  }
  return rest;
}

// The largest semantic class id (the semantic-id target's classes are 16-bit).
constexpr uint32_t kMaxSemantic = 65535;

void unite(scene::Bounds& into, const scene::Bounds& b) {
  if (b.empty()) return;
  into.extend(b.min);
  into.extend(b.max);
}

}  // namespace

glm::mat4 ObjectTransform::local() const {
  if (matrix) return *matrix;
  return glm::translate(glm::mat4(1.0f), translation) * glm::mat4_cast(rotation) *
         glm::scale(glm::mat4(1.0f), scale);
}

// ---- Assets.

const Asset* SceneGraph::findAsset(std::string_view id) const {
  for (const Asset& a : assets_) {
    if (a.id == id) return &a;
  }
  return nullptr;
}

const Asset& SceneGraph::asset(std::string_view id) const {
  if (const Asset* a = findAsset(id)) return *a;
  throw ProblemError(notFoundDetail("The session has no asset " + quoteClientText(id) +
                                    " (GET .../assets lists them)."));
}

std::pair<const Asset*, bool> SceneGraph::addAsset(Asset asset) {
  if (const Asset* same = findAsset(asset.id)) return {same, false};
  if (assets_.size() >= kMaxAssets) {
    throw ProblemError(limitExceeded(
        413, std::string(protocol::limits::kMaxAssetsPerSession),
        "A session holds at most " + std::to_string(kMaxAssets) +
            " assets; delete one no object uses (DELETE .../assets/{aid}) first."));
  }
  asset.bounds = asset.scene->bounds();
  asset.animated = scene::animated(*asset.scene);
  assets_.push_back(std::move(asset));
  return {&assets_.back(), true};
}

size_t SceneGraph::usersOf(const Asset& asset) const {
  const uint32_t first = asset.firstMaterial;
  const uint32_t end = first + uint32_t(asset.scene->materials.size());
  return size_t(std::count_if(objects_.begin(), objects_.end(), [&](const auto& entry) {
    const SceneObject& o = entry.second;
    return o.asset == asset.id || (o.material && *o.material >= first && *o.material < end);
  }));
}

std::pair<uint32_t, uint32_t> SceneGraph::removeAsset(std::string_view id) {
  const Asset& gone = asset(id);
  const uint32_t first = gone.firstMaterial;
  const uint32_t count = uint32_t(gone.scene->materials.size());
  for (const auto& [objectId, o] : objects_) {
    if (o.asset == gone.id) {
      throw ProblemError(conflict("Asset " + quoteClientText(id) + " is in use: object " +
                                  std::to_string(objectId) + " draws it (" +
                                  std::to_string(usersOf(gone)) +
                                  " objects use it). Delete them first."));
    }
    if (o.material && *o.material >= first && *o.material < first + count) {
      throw ProblemError(conflict("Asset " + quoteClientText(id) + " is in use: object " +
                                  std::to_string(objectId) + " is drawn with its material " +
                                  std::to_string(*o.material) + "."));
    }
  }
  for (auto& [objectId, o] : objects_) {
    if (o.material && *o.material >= first + count) *o.material -= count;
  }
  const auto it = std::find_if(assets_.begin(), assets_.end(),
                               [&](const Asset& a) { return a.id == id; });
  for (auto later = it + 1; later != assets_.end(); ++later) later->firstMaterial -= count;
  assets_.erase(it);
  return {first, count};
}

// ---- Objects.

uint32_t SceneGraph::objectId(std::string_view segment) const {
  uint32_t id = 0;
  auto [end, ec] = std::from_chars(segment.data(), segment.data() + segment.size(), id);
  if (segment.empty() || ec != std::errc() || end != segment.data() + segment.size() ||
      !objects_.contains(id)) {
    throw ProblemError(notFoundDetail("The session has no object " + quoteClientText(segment) +
                                      " (GET .../objects lists them)."));
  }
  return id;
}

const SceneObject& SceneGraph::object(uint32_t id) const {
  const auto it = objects_.find(id);
  if (it == objects_.end()) {
    throw ProblemError(notFoundDetail("The session has no object " + std::to_string(id) + "."));
  }
  return it->second;
}

void SceneGraph::check(const SceneObject& o, uint32_t materials,
                       const std::map<uint32_t, SceneObject>& pending,
                       const std::string& pointer) const {
  if (findAsset(o.asset) == nullptr) {
    throw ProblemError(invalidBody(pointer + "/asset", "The session has no asset " +
                                                           quoteClientText(o.asset) +
                                                           " (POST .../assets adds one)."));
  }
  const size_t clips = findAsset(o.asset)->scene->animations.size();
  const size_t nodes = findAsset(o.asset)->scene->nodes.size();
  if (o.node >= 0 && size_t(o.node) >= nodes) {
    throw ProblemError(invalidBody(
        pointer + "/node", "Asset " + quoteClientText(o.asset) + " has " + std::to_string(nodes) +
                               " nodes; there is no node " + std::to_string(o.node) + "."));
  }
  if (o.clip >= 0 && size_t(o.clip) >= std::max<size_t>(clips, 1)) {
    throw ProblemError(
        invalidBody(pointer + "/animation/clip",
                    "Asset " + quoteClientText(o.asset) + " has " + std::to_string(clips) +
                        " animation clips; there is no clip " + std::to_string(o.clip) + "."));
  }
  // Only the rest transform: O(depth), so a node tree of thousands of objects checks quickly.
  if (o.node >= 0 && !usable(glm::inverse(restWorld(*findAsset(o.asset)->scene, o.node)))) {
    throw ProblemError(
        invalidBody(pointer + "/node", "Node " + std::to_string(o.node) + " of asset " +
                                           quoteClientText(o.asset) +
                                           " cannot be placed: its rest transform is singular."));
  }
  const glm::mat4 local = o.transform.local();
  if (!usable(local)) {
    throw ProblemError(invalidBody(
        pointer + "/transform",
        "The transform must be finite, affine and invertible (no zero scale, a non-zero "
        "rotation quaternion, a matrix whose last row is 0 0 0 1)."));
  }
  if (o.material && *o.material >= materials) {
    throw ProblemError(invalidBody(pointer + "/material",
                                   "The session has no material " + std::to_string(*o.material) +
                                       " (it has " + std::to_string(materials) + ")."));
  }
  // The chain of parents: each must exist, none may be the object, and it may be at most
  // kMaxDepth long.
  size_t depth = 0;
  for (uint32_t p = o.parent; p != 0; ++depth) {
    if (p == o.id) {
      throw ProblemError(invalidBody(pointer + "/parent",
                                     "Object " + std::to_string(o.id) + " cannot be its own "
                                     "ancestor: parent " + std::to_string(o.parent) +
                                     " makes a cycle."));
    }
    if (depth >= kMaxDepth) {
      throw ProblemError(invalidBody(pointer + "/parent",
                                     "Objects nest at most " + std::to_string(kMaxDepth) +
                                         " deep."));
    }
    const auto pendingIt = pending.find(p);
    const SceneObject* parent = pendingIt != pending.end() ? &pendingIt->second : nullptr;
    if (parent == nullptr) {
      const auto it = objects_.find(p);
      if (it != objects_.end()) parent = &it->second;
    }
    if (parent == nullptr) {
      throw ProblemError(invalidBody(pointer + "/parent",
                                     "The session has no object " + std::to_string(p) +
                                         " to be the parent."));
    }
    p = parent->parent;
  }
}

std::vector<uint32_t> SceneGraph::addObjects(std::vector<SceneObject> objects, uint32_t materials,
                                             std::string_view pointer) {
  if (uint64_t(objects_.size()) + objects.size() > maxObjects_) {
    throw ProblemError(limitExceeded(
        413, std::string(protocol::limits::kMaxObjectsPerSession),
        "This would leave the session with " + std::to_string(objects_.size() + objects.size()) +
            " objects; it may hold at most " + std::to_string(maxObjects_) + "."));
  }
  if (uint64_t(nextId_) + objects.size() >= UINT32_MAX) {
    throw ProblemError(limitExceeded(413, std::string(protocol::limits::kMaxObjectsPerSession),
                                     "The session has given out every object id."));
  }
  std::map<uint32_t, SceneObject> pending;
  std::vector<uint32_t> ids;
  ids.reserve(objects.size());
  uint32_t id = nextId_;
  for (size_t i = 0; i < objects.size(); ++i, ++id) {
    objects[i].id = id;
    // A parent added in the same request must come before its children.
    if (objects[i].parent >= id) {
      throw ProblemError(invalidBody(std::string(pointer) + "/" + std::to_string(i) + "/parent",
                                     "The parent " + std::to_string(objects[i].parent) +
                                         " is not an object of the session or an earlier one "
                                         "of this request (this one gets id " +
                                         std::to_string(id) + ")."));
    }
    check(objects[i], materials, pending, std::string(pointer) + "/" + std::to_string(i));
    pending.emplace(id, objects[i]);
    ids.push_back(id);
  }
  std::vector<SceneObject*> added;
  for (auto& [pendingId, o] : pending) added.push_back(&o);
  assignClasses(std::move(added), pointer, true);
  objects_.merge(pending);
  // New ids are above every id there is: appended, each list stays ascending.
  for (uint32_t added : ids) {
    if (const uint32_t parent = objects_.at(added).parent; parent != 0) {
      children_[parent].push_back(added);
    }
  }
  nextId_ = id;
  return ids;
}

void SceneGraph::replaceObject(const SceneObject& next, uint32_t materials) {
  const uint32_t parent = object(next.id).parent;
  check(next, materials, {}, "");
  SceneObject taken = next;
  assignClasses({&taken}, "", false);
  objects_[next.id] = std::move(taken);
  if (parent != next.parent) {
    unlinkChild(parent, next.id);
    linkChild(next.parent, next.id);
  }
}

void SceneGraph::indexChildren() {
  children_.clear();
  for (const auto& [id, o] : objects_) {
    if (o.parent != 0) children_[o.parent].push_back(id);
  }
}

void SceneGraph::unlinkChild(uint32_t parent, uint32_t child) {
  const auto it = children_.find(parent);
  if (parent == 0 || it == children_.end()) return;
  std::erase(it->second, child);
  if (it->second.empty()) children_.erase(it);
}

void SceneGraph::linkChild(uint32_t parent, uint32_t child) {
  if (parent == 0) return;
  std::vector<uint32_t>& list = children_[parent];
  list.insert(std::lower_bound(list.begin(), list.end(), child), child);
}

void SceneGraph::assignClasses(std::vector<SceneObject*> objects, std::string_view pointer,
                               bool indexed) {
  if (std::none_of(objects.begin(), objects.end(),
                   [](const SceneObject* o) { return !o->semanticClass.empty(); })) {
    return;
  }
  // Ids taken: every class's, and every integer an object (kept or coming) was given.
  std::vector<bool> used(kMaxSemantic + 1, false);
  used[0] = true;
  for (const auto& [name, id] : classes_) used[std::min(id, kMaxSemantic)] = true;
  std::vector<uint32_t> coming;  // an object being replaced counts as it will be
  for (const SceneObject* o : objects) coming.push_back(o->id);
  std::sort(coming.begin(), coming.end());
  for (const auto& [id, o] : objects_) {
    if (o.semanticClass.empty() && !std::binary_search(coming.begin(), coming.end(), id)) {
      used[std::min(o.semantic, kMaxSemantic)] = true;
    }
  }
  for (const SceneObject* o : objects) {
    if (o->semanticClass.empty()) used[std::min(o->semantic, kMaxSemantic)] = true;
  }
  std::map<std::string, uint32_t, std::less<>> classes = classes_;
  uint32_t next = 1;
  for (size_t i = 0; i < objects.size(); ++i) {
    SceneObject& o = *objects[i];
    if (o.semanticClass.empty()) continue;
    if (const auto it = classes.find(o.semanticClass); it != classes.end()) {
      o.semantic = it->second;
      continue;
    }
    while (next <= kMaxSemantic && used[next]) ++next;
    if (next > kMaxSemantic) {
      throw ProblemError(invalidBody(
          std::string(pointer) + (indexed ? "/" + std::to_string(i) : "") + "/semantic",
          "The session has no semantic class id left for " + quoteClientText(o.semanticClass) +
              ": every id from 1 to " + std::to_string(kMaxSemantic) +
              " is a class or an object's integer."));
    }
    used[next] = true;
    classes.emplace(o.semanticClass, next);
    o.semantic = next;
  }
  classes_ = std::move(classes);
}

size_t SceneGraph::removeObject(uint32_t id) {
  object(id);
  const std::vector<uint32_t> gone = subtree(id);
  unlinkChild(object(id).parent, id);
  for (uint32_t g : gone) {
    objects_.erase(g);
    children_.erase(g);
  }
  return gone.size();
}

void SceneGraph::restoreObjects(std::vector<SceneObject> objects, uint32_t nextId,
                                uint32_t materials, std::string_view pointer,
                                const std::vector<std::pair<std::string, uint32_t>>& classes,
                                std::string_view classesPointer) {
  if (objects.size() > maxObjects_) {
    throw ProblemError(limitExceeded(
        413, std::string(protocol::limits::kMaxObjectsPerSession),
        "The snapshot holds " + std::to_string(objects.size()) +
            " objects; a session may hold at most " + std::to_string(maxObjects_) + "."));
  }
  SceneGraph next = *this;
  next.objects_.clear();
  std::map<uint32_t, SceneObject> all;
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::string at = std::string(pointer) + "/" + std::to_string(i);
    if (objects[i].id == 0 || objects[i].id >= nextId || all.contains(objects[i].id)) {
      throw ProblemError(invalidBody(at + "/id", "Object ids are distinct, from 1, and below "
                                                 "the snapshot's nextObjectId."));
    }
    all.emplace(objects[i].id, objects[i]);
  }
  for (size_t i = 0; i < objects.size(); ++i) {
    next.check(objects[i], materials, all, std::string(pointer) + "/" + std::to_string(i));
  }
  // The snapshot's classes as they were (a name keeps its id); names objects give that it does
  // not list get ids as new names do.
  std::map<std::string, uint32_t, std::less<>> names;
  std::vector<bool> ids(kMaxSemantic + 1, false);
  for (size_t i = 0; i < classes.size(); ++i) {
    const auto& [name, id] = classes[i];
    if (name.empty() || id == 0 || id > kMaxSemantic || ids[id] || names.contains(name)) {
      throw ProblemError(invalidBody(
          std::string(classesPointer) + "/" + std::to_string(i),
          "Semantic classes have distinct non-empty names and distinct ids from 1 to " +
              std::to_string(kMaxSemantic) + "."));
    }
    ids[id] = true;
    names.emplace(name, id);
  }
  next.objects_.clear();
  next.classes_ = std::move(names);
  std::vector<SceneObject*> restored;
  for (auto& [id, o] : all) restored.push_back(&o);
  next.assignClasses(std::move(restored), pointer, true);
  objects_ = std::move(all);
  indexChildren();
  nextId_ = nextId;
  classes_ = std::move(next.classes_);
}

void SceneGraph::clear() {
  assets_.clear();
  objects_.clear();
  children_.clear();
  placements_.clear();
  placed_.clear();
  flattenedFrom_.clear();
}

std::vector<uint32_t> SceneGraph::subtree(uint32_t id) const {
  // Level by level (at most kMaxDepth), each level ascending, from the children index: a move
  // of one object among 100,000 looks at its own children only.
  std::vector<uint32_t> out{id};
  std::vector<uint32_t> level{id};
  while (!level.empty()) {
    std::vector<uint32_t> next;
    for (uint32_t parent : level) {
      if (const auto it = children_.find(parent); it != children_.end()) {
        next.insert(next.end(), it->second.begin(), it->second.end());
      }
    }
    std::sort(next.begin(), next.end());
    out.insert(out.end(), next.begin(), next.end());
    level = std::move(next);
  }
  return out;
}

glm::mat4 SceneGraph::worldOf(uint32_t id) const {
  glm::mat4 world(1.0f);
  for (uint32_t p = id; p != 0;) {
    const SceneObject& o = object(p);
    world = o.transform.local() * world;
    p = o.parent;
  }
  return world;
}

bool SceneGraph::shown(uint32_t id) const {
  for (uint32_t p = id; p != 0;) {
    const SceneObject& o = object(p);
    if (!o.visible) return false;
    p = o.parent;
  }
  return true;
}

// ---- The flat scene.

std::shared_ptr<scene::Scene> SceneGraph::flatten(const std::vector<scene::Material>& materials) {
  auto flat = std::make_shared<scene::Scene>();
  flat->materials = materials;
  std::unordered_map<std::string_view, const Asset*> byId;
  std::unordered_map<std::string_view, uint32_t> meshBase, nodeBase, skinBase;
  flattenedFrom_.clear();
  for (const Asset& a : assets_) {
    byId[a.id] = &a;
    meshBase[a.id] = uint32_t(flat->meshes.size());
    // Nodes and skins (what the renderer's rest pose reads), moved to where they go.
    const int32_t firstNode = int32_t(flat->nodes.size());
    nodeBase[a.id] = uint32_t(firstNode);
    skinBase[a.id] = uint32_t(flat->skins.size());
    for (scene::Node node : a.scene->nodes) {
      if (node.parent >= 0) node.parent += firstNode;
      flat->nodes.push_back(std::move(node));
    }
    for (scene::Skin skin : a.scene->skins) {
      for (uint32_t& joint : skin.joints) joint += uint32_t(firstNode);
      flat->skins.push_back(std::move(skin));
    }
    const uint32_t imageBase = uint32_t(flat->images.size());
    flat->meshes.insert(flat->meshes.end(), a.scene->meshes.begin(), a.scene->meshes.end());
    flat->images.insert(flat->images.end(), a.scene->images.begin(), a.scene->images.end());
    // The asset's materials name its own images: shift them to where its images went.
    for (size_t m = 0; m < a.scene->materials.size(); ++m) {
      scene::Material& material = flat->materials.at(a.firstMaterial + m);
      for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
        scene::TextureRef& ref = material.texture(slot);
        if (ref.present()) ref.image += imageBase;
      }
    }
    flattenedFrom_.push_back(a.scene);
  }
  placements_.clear();
  placed_.clear();
  // Per (asset, node) of node objects: the asset instances below the node, and the inverse of
  // the node's rest world transform.
  std::map<std::pair<const Asset*, int32_t>, std::pair<std::vector<uint32_t>, glm::mat4>> subtrees;
  std::unordered_map<const Asset*, std::vector<std::vector<uint32_t>>> ownInstances;
  for (const auto& [id, o] : objects_) {
    Placement placement{uint32_t(flat->instances.size()), 0, {}, glm::mat4(1.0f)};
    if (shown(id)) {
      const Asset& a = *byId.at(o.asset);
      const glm::mat4 world = worldOf(id);
      const bool ofNode = o.node >= 0 && size_t(o.node) < a.scene->nodes.size();
      if (ofNode && !o.subtree) {
        // A node's own instances: an index per asset, built once, so a tree of thousands of
        // node objects costs one pass over its instances.
        auto it = ownInstances.find(&a);
        if (it == ownInstances.end()) {
          std::vector<std::vector<uint32_t>> own(a.scene->nodes.size());
          for (uint32_t k = 0; k < a.scene->instances.size(); ++k) {
            const int32_t n = a.scene->instances[k].node;
            if (n >= 0 && size_t(n) < own.size()) own[size_t(n)].push_back(k);
          }
          it = ownInstances.emplace(&a, std::move(own)).first;
        }
        placement.assetInstances = it->second[size_t(o.node)];
        placement.fromNode = glm::inverse(restWorld(*a.scene, o.node));
      } else if (ofNode) {
        auto it = subtrees.find({&a, o.node});
        if (it == subtrees.end())
          it = subtrees.emplace(std::make_pair(&a, o.node), nodeSubtree(*a.scene, o.node)).first;
        placement.assetInstances = it->second.first;
        placement.fromNode = it->second.second;
      }
      const uint32_t drawn =
          ofNode ? uint32_t(placement.assetInstances.size()) : uint32_t(a.scene->instances.size());
      for (uint32_t j = 0; j < drawn; ++j) {
        const uint32_t k = ofNode ? placement.assetInstances[j] : j;
        const scene::Instance& inst = a.scene->instances[k];
        scene::Instance out = inst;
        out.mesh += meshBase.at(o.asset);
        if (out.node >= 0) out.node += int32_t(nodeBase.at(o.asset));
        if (out.skin >= 0) out.skin += int32_t(skinBase.at(o.asset));
        out.material = o.material.value_or(a.firstMaterial + inst.material);
        const glm::mat4 assetTransform = placement.fromNode * inst.transform;
        out.transform = world * assetTransform;
        out.object = id;
        out.semantic = o.semantic;
        const scene::Mesh* mesh =
            inst.mesh < a.scene->meshes.size() ? &a.scene->meshes[inst.mesh] : nullptr;
        placed_.push_back(
            {mesh, assetTransform,
             mesh != nullptr ? scene::transformedBounds(*mesh, out.transform) : scene::Bounds{}});
        flat->instances.push_back(out);
        ++placement.count;
      }
    }
    placements_[id] = placement;
  }
  uniteBounds();
  return flat;
}

std::pair<std::vector<uint32_t>, glm::mat4> SceneGraph::nodeSubtree(const scene::Scene& asset,
                                                                    int32_t node) {
  // Parents come first (scene::Node::parent), so one pass marks every node below `node`.
  std::vector<uint8_t> below(asset.nodes.size(), 0);
  below[size_t(node)] = 1;
  for (size_t i = size_t(node) + 1; i < asset.nodes.size(); ++i) {
    const int32_t parent = asset.nodes[i].parent;
    below[i] = parent >= 0 && size_t(parent) < i && below[size_t(parent)];
  }
  std::vector<uint32_t> instances;
  for (uint32_t k = 0; k < asset.instances.size(); ++k) {
    const int32_t n = asset.instances[k].node;
    if (n >= 0 && size_t(n) < below.size() && below[size_t(n)]) instances.push_back(k);
  }
  return {std::move(instances), glm::inverse(restWorld(asset, node))};
}

std::vector<SceneObject> nodeTreeObjects(const Asset& asset, uint32_t firstId,
                                         const std::string& rootName, size_t room) {
  const scene::Scene& a = *asset.scene;
  const size_t nodes = a.nodes.size();
  if (nodes < 2 || nodes > std::min(kMaxTreeObjects, room) || !a.skins.empty()) return {};
  std::vector<uint8_t> drawn(nodes, 0);
  for (const scene::Instance& inst : a.instances) {
    if (inst.node < 0 || size_t(inst.node) >= nodes) return {};  // an instance of no node
    drawn[size_t(inst.node)] = 1;
  }
  if (std::count(drawn.begin(), drawn.end(), 1) < 2) return {};
  std::vector<SceneObject> out;
  out.reserve(nodes);
  for (size_t n = 0; n < nodes; ++n) {
    const scene::Node& node = a.nodes[n];
    // Parents come first; one root only (node 0), so the tree hangs from one object.
    if ((n == 0) != (node.parent < 0) || node.parent >= int32_t(n)) return {};
    SceneObject o;
    o.id = firstId + uint32_t(n);
    o.name = n == 0 ? rootName : node.name;
    // Names are at most 256 characters (object.schema.json): cut on a UTF-8 character boundary.
    if (o.name.size() > 256) {
      size_t cut = 256;
      while (cut > 0 && (static_cast<unsigned char>(o.name[cut]) & 0xC0) == 0x80) --cut;
      o.name.resize(cut);
    }
    o.asset = asset.id;
    o.transform.translation = node.translation;
    o.transform.rotation = node.rotation;
    o.transform.scale = node.scale;
    o.parent = n == 0 ? 0 : firstId + uint32_t(node.parent);
    o.node = int32_t(n);
    o.subtree = false;
    out.push_back(std::move(o));
  }
  return out;
}

bool SceneGraph::playing() const {
  if (std::none_of(assets_.begin(), assets_.end(),
                   [](const Asset& a) { return !a.scene->animations.empty(); })) {
    return false;
  }
  for (const auto& [id, o] : objects_) {
    if (o.clip < 0) continue;
    const Asset* a = findAsset(o.asset);
    if (a != nullptr && !a->scene->animations.empty() && shown(id)) return true;
  }
  return false;
}

void SceneGraph::uniteBounds() {
  bounds_ = {};
  for (const Placed& p : placed_) unite(bounds_, p.bounds);
}

scene::Bounds SceneGraph::drawnBounds(uint32_t id) const {
  scene::Bounds out;
  const Placement* p = placement(id);
  for (uint32_t i = 0; p != nullptr && i < p->count && p->first + i < placed_.size(); ++i) {
    unite(out, placed_[p->first + i].bounds);
  }
  return out;
}

const SceneGraph::Placement* SceneGraph::placement(uint32_t id) const {
  const auto it = placements_.find(id);
  return it == placements_.end() ? nullptr : &it->second;
}

void SceneGraph::placeInstances(uint32_t id, std::vector<render::InstanceWrite>* writes) {
  const Placement* placement = this->placement(id);
  if (placement == nullptr || placement->count == 0) return;
  const glm::mat4 world = worldOf(id);
  for (uint32_t i = placement->first; i < placement->first + placement->count; ++i) {
    Placed& p = placed_[i];
    const glm::mat4 transform = world * p.assetTransform;
    p.bounds = p.mesh != nullptr ? scene::transformedBounds(*p.mesh, transform) : scene::Bounds{};
    writes->push_back({i, transform});
  }
}

std::vector<SceneGraph::PlacedMesh> SceneGraph::placedMeshes(uint32_t id) const {
  std::vector<PlacedMesh> meshes;
  const Placement* placement = this->placement(id);
  if (placement == nullptr) return meshes;
  const glm::mat4 world = worldOf(id);
  for (uint32_t i = placement->first; i < placement->first + placement->count; ++i) {
    if (placed_[i].mesh != nullptr) meshes.push_back({placed_[i].mesh, world * placed_[i].assetTransform});
  }
  return meshes;
}

render::InstanceUpdate SceneGraph::moved(uint32_t id) {
  render::InstanceUpdate update;
  for (uint32_t moved : subtree(id)) placeInstances(moved, &update.writes);
  uniteBounds();
  update.bounds = bounds_;
  return update;
}

}  // namespace myriad::service
