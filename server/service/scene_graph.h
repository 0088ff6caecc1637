// A session's scene as assets and objects: what the API edits object by object, and the flat
// scene::Scene the renderer draws made from it.
//
// An *asset* is what one model load makes (meshes, materials, images, the file's instances),
// stored once per session under a content address (the same bytes uploaded twice are one asset).
// An *object* places one asset in the world: a name, a transform relative to its parent object
// (or the world), visibility, an optional material override and a semantic class. Objects are
// drawn in id order; each becomes its asset's instances, moved by the object's world transform.
//
// Plain data and rules: no HTTP, no Vulkan, no locking (SessionScene owns one; the session's
// mutex guards it). Client mistakes are thrown as ProblemError (404 for a missing asset or object,
// 409 for an asset still in use, 413 past a limit, 400 naming the member); an edit that throws
// changes nothing.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::service {

// An object's transform as its client gave it: translation, rotation and scale (applied scale
// first, then rotation, then translation, as glTF's TRS), or a whole 4x4 matrix.
struct ObjectTransform {
  glm::vec3 translation{0.0f};
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // unit (w, x, y, z in glm's constructor)
  glm::vec3 scale{1.0f};
  std::optional<glm::mat4> matrix;  // when given, the transform (TRS ignored)

  glm::mat4 local() const;
};

struct SceneObject {
  uint32_t id = 0;  // from 1, never reused in a session; the instance-id label of its pixels
  std::string name;
  std::string asset;  // an asset id
  ObjectTransform transform;
  bool visible = true;
  uint32_t parent = 0;               // 0: placed in the world
  std::optional<uint32_t> material;  // a session material id drawn instead of the asset's
  // The semantic class id (0: none); given as a class name (`semanticClass` not empty), the id
  // the graph maps that name to (SceneGraph::classes), set by the graph when it takes the object.
  uint32_t semantic = 0;
  std::string semanticClass;
  // Which of its asset's animations it plays on the session's clock (an index into the asset's
  // Scene::animations; -1: none, the rest pose) and whether the clip loops or holds its last
  // key. Assets without animations ignore both.
  int32_t clip = 0;
  bool loop = true;
  // The asset node it instances (index into the asset's Scene::nodes; -1: the whole asset): it
  // then draws the instances of that node and of the nodes below it, placed relative to the
  // node (its transform takes the place of the node's rest world transform in the asset).
  int32_t node = -1;
  // With a node: whether it draws the nodes below the node too (true), or the node's own
  // instances only (false: a node tree as objects, each node its own object; nodeTreeObjects).
  bool subtree = true;
};

struct Asset {
  std::string id;      // "a-" + 16 hex digits of the SHA-256 of what it was made from
  std::string source;  // builtin, library:NAME or upload:FILE
  uint64_t bytes = 0;  // of the upload (0 for the built-in scene and library models)
  // Its meshes, images, instances and (as loaded) materials; lights and cameras are not used.
  std::shared_ptr<const scene::Scene> scene;
  uint32_t firstMaterial = 0;  // the session material id of its material 0
  scene::Bounds bounds;        // of its instances, in its own space
  bool animated = false;       // scene::animated(): it has skins, morph targets or animations
};

// The objects that make `asset`'s node tree addressable (PUT .../model): one per node, in node
// order (ids from `firstId`), each drawing that node's own instances (subtree false) with the
// node's local transform, under the object of its parent node; the root node's object is named
// `rootName`. Empty when the tree is not worth it or cannot be split: fewer than two nodes with
// instances, more than kMaxTreeObjects nodes (or `room`), more than one root, or skins (a skinned
// mesh is placed by its joints, not by its node).
inline constexpr size_t kMaxTreeObjects = 4096;
std::vector<SceneObject> nodeTreeObjects(const Asset& asset, uint32_t firstId,
                                         const std::string& rootName, size_t room);

class SceneGraph {
 public:
  // Most assets a session holds at once.
  static constexpr size_t kMaxAssets = 64;
  // Deepest chain of parents: bounds the work of placing one object.
  static constexpr size_t kMaxDepth = 64;

  explicit SceneGraph(uint32_t maxObjects = 100000) : maxObjects_(maxObjects) {}

  uint32_t maxObjects() const { return maxObjects_; }

  // ---- Assets, in the order they were added.

  const std::vector<Asset>& assets() const { return assets_; }
  // Throws ProblemError 404 when there is none of that id.
  const Asset& asset(std::string_view id) const;
  const Asset* findAsset(std::string_view id) const;
  // Adds an asset (its materials get the session material ids from `firstMaterial` on). Returns
  // it and whether it is new: an asset of the same id is kept as it was. Throws ProblemError 413
  // maxAssetsPerSession past kMaxAssets.
  std::pair<const Asset*, bool> addAsset(Asset asset);
  // Removes an asset no object uses (ProblemError 409 otherwise, naming an object) and returns
  // the range of session material ids it held; later assets' materials move down by its count,
  // as do material overrides past it (an override into its range is a use: 409).
  std::pair<uint32_t, uint32_t> removeAsset(std::string_view id);
  // How many objects draw `id` (or override a material with one of its materials).
  size_t usersOf(const Asset& asset) const;

  // ---- Objects, by id.

  const std::map<uint32_t, SceneObject>& objects() const { return objects_; }
  // Throws ProblemError 404 when there is no such object (or `segment` is not a decimal id).
  uint32_t objectId(std::string_view segment) const;
  const SceneObject& object(uint32_t id) const;
  uint32_t nextObjectId() const { return nextId_; }

  // Adds objects (their `id`s are ignored and given from nextObjectId()). A parent may be an
  // existing object or one earlier in `objects` (by the id it will get). Checks all before adding
  // any: ProblemError 400 under `pointer`/i for a missing asset, parent or material, a transform
  // that is not finite and invertible; 413 maxObjectsPerSession past maxObjects(). `materials`:
  // how many session materials there are.
  std::vector<uint32_t> addObjects(std::vector<SceneObject> objects, uint32_t materials,
                                   std::string_view pointer);
  // Replaces object `next.id` by `next` (same checks; a parent that is the object or one of its
  // descendants is 400 /parent).
  void replaceObject(const SceneObject& next, uint32_t materials);
  // Removes the object and its descendants; returns how many.
  size_t removeObject(uint32_t id);
  // Takes `objects` (ids kept), `nextId` and `classes` (name -> id) as they are: a snapshot's.
  // Same checks as addObjects; a class listed twice (name or id) is 400 under `classesPointer`.
  void restoreObjects(std::vector<SceneObject> objects, uint32_t nextId, uint32_t materials,
                      std::string_view pointer,
                      const std::vector<std::pair<std::string, uint32_t>>& classes = {},
                      std::string_view classesPointer = "");
  // The session's semantic class names and their ids. A name's id stays for the session's life
  // (a model load or the deletion of every object using it keeps it); a snapshot brings its own.
  const std::map<std::string, uint32_t, std::less<>>& classes() const { return classes_; }
  void clear();
  // Replaces the asset list (a snapshot's, in its order; firstMaterial set by the caller). The
  // objects must be restored after it (restoreObjects), which checks them against it.
  void replaceAssets(std::vector<Asset> assets) { assets_ = std::move(assets); }

  // World transform of an object (its parents' times its own).
  glm::mat4 worldOf(uint32_t id) const;
  bool shown(uint32_t id) const;  // visible, and so are all its parents

  // ---- What the renderer draws.

  // The flat scene of every asset's meshes and images and every shown object's instances, with
  // `materials` (the session's, in asset order) and no lights. Remembers where each object's
  // instances went, for moved().
  std::shared_ptr<scene::Scene> flatten(const std::vector<scene::Material>& materials);
  // After object `id`'s transform changed (and nothing else since flatten()): the new transforms
  // of its and its descendants' instances, and the scene's bounds now.
  render::InstanceUpdate moved(uint32_t id);
  // Of the last flatten() (and moved() since).
  const scene::Bounds& bounds() const { return bounds_; }
  // Whether some shown object of an animated asset plays a clip (frames then move with the clock).
  bool playing() const;
  // Where an object's instances are in the flat scene, and their bounds (empty when not shown).
  struct Placement {
    uint32_t first = 0;
    uint32_t count = 0;
    // An object of one asset node: the asset instances it draws (ascending), the flat
    // instances first.. in that order, and the inverse of the node's rest world transform,
    // which places them relative to the node. Empty and identity for a whole asset.
    std::vector<uint32_t> assetInstances;
    glm::mat4 fromNode{1.0f};
  };
  const Placement* placement(uint32_t id) const;
  // The world bounds of the instances object `id` draws now (empty when it draws none).
  scene::Bounds drawnBounds(uint32_t id) const;
  // An object's meshes as the last flatten() placed them (world transforms; rest pose), for
  // what the CPU measures of it (the labels' total pixels). Empty when it is not shown.
  struct PlacedMesh {
    const scene::Mesh* mesh = nullptr;
    glm::mat4 transform{1.0f};
  };
  std::vector<PlacedMesh> placedMeshes(uint32_t id) const;
  // Object `id` and the objects below it, parents first (from the children index: O(subtree)).
  std::vector<uint32_t> subtree(uint32_t id) const;

 private:
  // Checks one object against the graph plus `pending` (objects being added), for addObjects,
  // replaceObject and restoreObjects; `pointer` is where its problems point.
  void check(const SceneObject& object, uint32_t materials,
             const std::map<uint32_t, SceneObject>& pending, const std::string& pointer) const;
  // The instances of `asset` at or below node `node` (ascending) and the inverse of the node's
  // rest world transform (Placement).
  static std::pair<std::vector<uint32_t>, glm::mat4> nodeSubtree(const scene::Scene& asset,
                                                                 int32_t node);
  // Gives the objects whose semantic is a class name their class id, adding names not yet
  // known (the lowest id from 1 that no class and no object's integer, nor one of `objects`',
  // holds). Throws ProblemError 400 naming its /semantic when every id is taken; changes
  // nothing then.
  // `indexed`: the objects are a request's list (pointer/i); otherwise one object (pointer).
  void assignClasses(std::vector<SceneObject*> objects, std::string_view pointer, bool indexed);
  void placeInstances(uint32_t id, std::vector<render::InstanceWrite>* writes);
  void uniteBounds();

  uint32_t maxObjects_;
  std::vector<Asset> assets_;
  std::map<uint32_t, SceneObject> objects_;
  // Each parent's children, ascending (objects without children have no entry): kept with
  // objects_ by every edit, so a move of one object among 100,000 finds its subtree without a
  // pass over them all (that pass was most of a PATCH: 9 ms on the H100 host).
  std::unordered_map<uint32_t, std::vector<uint32_t>> children_;
  void indexChildren();  // children_ from objects_, afresh
  void unlinkChild(uint32_t parent, uint32_t child);
  void linkChild(uint32_t parent, uint32_t child);
  uint32_t nextId_ = 1;
  std::map<std::string, uint32_t, std::less<>> classes_;

  // Of the last flatten(): each object's instances, and per flat instance its asset's instance
  // transform and its world bounds.
  std::unordered_map<uint32_t, Placement> placements_;
  struct Placed {
    const scene::Mesh* mesh = nullptr;
    glm::mat4 assetTransform{1.0f};
    scene::Bounds bounds;
  };
  std::vector<Placed> placed_;
  std::vector<std::shared_ptr<const scene::Scene>> flattenedFrom_;  // keeps placed_'s meshes alive
  scene::Bounds bounds_;
};

}  // namespace myriad::service
