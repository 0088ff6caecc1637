// A session's scene on the CPU, and the only code that changes it: the model it shows (a summary),
// its materials, camera, settings and lights. Each edit is one method that checks what the edit
// must respect, changes the CPU copy, and returns the change the session's GPU scene needs (a
// render::LightUpdate, a render::MaterialWrite, a scene to upload), which the caller queues on the
// render queue in the same order, under the session's lock. Camera and settings go with every
// frame (frameSettings()), so their edits return nothing.
//
// Plain data and rules: no HTTP, no Vulkan, no locking (the Session's mutex guards it). Client
// mistakes are thrown as ProblemError (404 for a missing light or material, 413 for too many
// lights, 400 naming the member for an invalid value); an edit that throws changes nothing.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "protocol/constants.h"
#include "protocol/types.h"
#include "render/frame.h"
#include "scene/environment_map.h"
#include "scene/scene.h"
#include "service/scene_graph.h"

namespace myriad::service {

using Clock = std::chrono::steady_clock;

// What GET /v1/sessions/{id} reports about the loaded model.
struct ModelSummary {
  std::string source{protocol::kBuiltinModel};  // or protocol::kLibraryPrefix + NAME, kUploadPrefix + FILE
  size_t meshes = 0;
  size_t instances = 0;
  size_t materials = 0;
  scene::Bounds bounds;
  // The model's texture images (their pixels stay on the GPU): what a material's textures list.
  struct Image {
    std::string name;
    uint32_t width = 0, height = 0;
  };
  std::vector<Image> images;
  std::vector<scene::ModelCamera> cameras;  // the file's
  size_t pointLights = 0, spotLights = 0;    // the file's
  size_t directionalLights = 0;              // the file's, used or not
  size_t directionalDropped = 0;             // beyond scene::kMaxExtraSuns: not used
};

// How a session's lights were made, while they are still exactly what a generator made (the
// built-in scene's, or POST .../lights/generate with its defaults): loading another model can make
// them again around it. Any other light edit forgets it.
struct LightRecipe {
  uint32_t count = 0;
  uint64_t seed = 0;
};

// How adopt() treats what the session already has.
struct Adoption {
  enum class Lights {
    automatic,  // fit while the lights are still generated (a recipe is known), else keep
    keep,       // the session keeps its lights; the scene to upload gets them
    model,      // the model's own lights (new ids)
    fit,        // generated again around the new model: the recipe's count and seed, else the
                // current count with seed 1 (new ids)
  };
  Lights lights = Lights::keep;
  // With Lights::model: how the model's lights were generated (the built-in scene's), if they were.
  std::optional<LightRecipe> recipe;
  // Take the model's sun, ambient and background (a new session); otherwise keep the session's.
  bool lightingFromModel = false;
  // The model's asset id (SceneGraph: "a-" + hex of the SHA-256 of its bytes); empty: made from
  // the source's name (the built-in scene, a library model).
  std::string assetId;
  uint64_t assetBytes = 0;
};

// The asset id of what `content` names: "a-" + the first 16 hex digits of its SHA-256.
std::string assetIdOf(std::string_view content);

// What an object edit asks of the GPU scene: either new transforms for some instances (a move
// that changes nothing else) or the whole scene again.
struct SceneChange {
  std::optional<render::InstanceUpdate> moved;
  std::shared_ptr<const scene::Scene> scene;
};

class SessionScene {
 public:
  // An empty scene (no model, no lights) that holds at most `maxLights` lights and starts from
  // `settings` (the server's default technique among them).
  SessionScene(uint32_t maxLights, render::SceneSettings settings, uint32_t maxObjects = 100000);

  // ---- The model. Creating a session and loading a model both come through here.

  // Makes `loaded` the session's model: summary (from `source`), materials and camera, and, as
  // `adoption` says, its lights and its lighting. Returns the scene to upload to the GPU, holding
  // the session's lights as they are after the call. Throws ProblemError 413 maxLightsPerSession
  // when the model brings more lights than the session may hold (nothing changes then).
  std::shared_ptr<const scene::Scene> adopt(std::shared_ptr<scene::Scene> loaded,
                                            std::string source, Adoption adoption);

  const ModelSummary& model() const { return model_; }

  // ---- Assets and objects (SceneGraph). `adopt` makes the scene one asset and one root object;
  // these add to it. Each edit that changes what is drawn returns the change to queue.

  const SceneGraph& graph() const { return graph_; }
  // Adds `loaded` as asset `id` (or finds the same one) without drawing it: its materials join
  // the session's (ids from its firstMaterial). `added` says whether it is new; `scene` is the
  // scene to upload then (its materials are new), null otherwise.
  struct AssetAdded {
    const Asset* asset = nullptr;
    bool added = false;
    std::shared_ptr<const scene::Scene> scene;
  };
  AssetAdded addAsset(std::shared_ptr<const scene::Scene> loaded, std::string source,
                      std::string id, uint64_t bytes);
  // Removes an asset no object uses (409 otherwise); its materials go, and later ids move down.
  std::shared_ptr<const scene::Scene> removeAsset(std::string_view id);
  // SceneGraph::addObjects, and the scene to upload.
  std::shared_ptr<const scene::Scene> addObjects(std::vector<SceneObject> objects,
                                                 std::vector<uint32_t>* ids);
  // Replaces object `next.id` by `next`: a change of transform alone is a move (only its and its
  // descendants' instances are written), anything else uploads the scene.
  SceneChange replaceObject(const SceneObject& next);
  // Removes the object and its descendants (written to `removed` when given).
  std::shared_ptr<const scene::Scene> removeObject(uint32_t id, size_t* removed = nullptr);

  // ---- Camera and settings (carried by each frame; nothing to upload).

  const scene::Camera& camera() const { return camera_; }
  // Throws ProblemError 400 (pointer /far, /target or /up) for a camera no frame can use.
  const scene::Camera& setCamera(const scene::Camera& camera);
  const scene::Camera& patchCamera(const protocol::CameraPatch& patch);
  // Moves the eye along the current viewing direction until the whole model fits a view of
  // `aspect`, keeping the field of view.
  const scene::Camera& frameModel(float aspect);
  // Makes model camera `index` (ModelSummary::cameras) the session's camera, with its field of
  // view and planes (an infinite far plane becomes one past the model). Throws ProblemError 400
  // (pointer /modelCamera) for a camera the model does not have or an orthographic one.
  const scene::Camera& selectModelCamera(uint64_t index);

  const render::SceneSettings& settings() const { return settings_; }

  // ---- The environment's image (mode hdr): an equirectangular .hdr, resampled by the loader.
  // Setting one selects mode hdr (and counts as choosing the environment). `source` is what
  // GET .../environment reports ("upload:NAME" or "library:NAME").
  void setEnvironmentImage(std::shared_ptr<const scene::EnvironmentImage> image, std::string source);
  const std::shared_ptr<const scene::EnvironmentImage>& environmentImage() const {
    return environmentImage_;
  }
  const std::string& environmentSource() const { return environmentSource_; }
  // Throws ProblemError 400 (/sun/direction, /technique) for a value no frame can use. Switching
  // animation on restarts the animation clock at `now`, so lights start from where they are.
  const render::SceneSettings& patchSettings(const protocol::SettingsPatch& patch,
                                             Clock::time_point now);

  // Seconds of animation at `now` (0 when not animating).
  double animationSeconds(Clock::time_point now) const;

  // ---- The scene clock: the time at which objects play their assets' animation clips
  // (SceneObject::clip, loop). Separate from the lights' `animate` clock. It runs from the
  // session's start at rate 1; play, pause, seek and rate re-anchor it, so the time never jumps.
  struct SceneClock {
    double time = 0.0;  // seconds now
    bool playing = true;
    double rate = 1.0;      // clock seconds per wall second
    double duration = 0.0;  // the longest clip a shown object plays (0: nothing plays)
  };
  SceneClock clock(Clock::time_point now) const;
  double clockSeconds(Clock::time_point now) const;  // clock(now).time, without the duration
  // Any subset: playing (play/pause), time (seek), rate. Applied at `now`.
  SceneClock patchClock(std::optional<bool> playing, std::optional<double> time,
                        std::optional<double> rate, Clock::time_point now);
  // Whether frames change with time alone: the lights animate, or the clock plays a clip.
  bool moving() const;
  // The scene posed at clock time `seconds`: node-animated instances' transforms (each object's
  // world transform times its node's animated one) and skinned or morphed instances' joints and
  // weights, in the flat scene's instance indices. Null when nothing in the scene is animated.
  std::shared_ptr<const render::ScenePose> poseAt(double seconds) const;

  // The frame the session shows at `now`: `request`'s own choices (size, target, raw...) with the
  // session's camera and settings. `time` (a request's ?time=) shows the lights where the
  // animation has them then, animating or not; without it, where the session's clock has them.
  render::FrameSettings frameSettings(const render::FrameSettings& request,
                                      std::optional<double> time, Clock::time_point now) const;

  // ---- Materials (material id = index in the model's list).

  const std::vector<scene::Material>& materials() const { return materials_; }
  // The material `id` names (a route segment: decimal digits); throws ProblemError 404 when the
  // model has no such material.
  uint32_t materialId(std::string_view id) const;
  // Changes the members `patch` names of material `id` (from materialId).
  render::MaterialWrite patchMaterial(uint32_t id, const protocol::MaterialPatch& patch);
  // Material `id` as its asset's model file gave it (before any patch).
  const scene::Material& loadedMaterial(uint32_t id) const;

  // ---- Snapshots: the whole state but the model's bytes, as one document.

  protocol::Snapshot snapshot() const;
  // The semantic class names objects were given and their ids, by id (labels, snapshots).
  std::vector<protocol::SemanticClass> semanticClasses() const;

  // What restore() asks of the GPU scene.
  struct Restored {
    // The scene to upload first, when the snapshot's objects replaced the session's.
    std::shared_ptr<const scene::Scene> scene;
    render::LightUpdate lights;
    std::vector<render::MaterialWrite> materials;
  };
  // Takes `snapshot`'s camera, settings, material factors (by id) and lights; the model stays
  // (the caller loads the snapshot's model first, when it is to change). Everything is checked
  // before anything changes: ProblemError 400 with a JSON Pointer under `pointer` ("/snapshot"
  // in POST /v1/sessions, "" for PUT .../snapshot) for a camera, sun, technique, material id or
  // lights member no frame can use, 413 maxLightsPerSession for too many lights.
  // `image`: the snapshot's library environment image (settings.environment.source), loaded by
  // the caller, taken with the rest (the caller then gives it to the GPU scene).
  // What a restore needs that the caller loads without the session's lock: the snapshot's
  // library environment image, and the builtin and library assets of its scene the session may
  // lack (an uploaded asset must already be the session's).
  struct SnapshotLoads {
    std::shared_ptr<const scene::EnvironmentImage> image;
    std::string source;
    std::vector<Asset> assets;
  };
  Restored restore(const protocol::Snapshot& snapshot, std::string_view pointer,
                   Clock::time_point now, const SnapshotLoads& image = {});

  // ---- Lights. Each light has a stable id (never reused within the session) and a slot, its
  // index in the GPU's light array. Slots are dense: removing a light moves the last light into
  // its slot, on the CPU and (by the returned update) on the GPU alike.

  uint32_t maxLights() const { return maxLights_; }
  size_t lightCount() const { return lights_.size(); }
  const scene::PointLight& lightAt(uint32_t slot) const { return lights_[slot]; }
  std::span<const scene::PointLight> lights() const { return lights_; }  // by slot
  uint64_t idAt(uint32_t slot) const { return ids_[slot]; }
  // The slot of the light `id` names (a route segment: decimal digits); throws ProblemError 404
  // when the session has no such light (deleted, never created, or not a number).
  uint32_t slotOf(std::string_view id) const;

  // Appends `lights` with fresh ids, written to `ids` when given. Throws ProblemError 413
  // maxLightsPerSession when the total would pass maxLights().
  render::LightUpdate addLights(std::span<const scene::PointLight> lights,
                                std::vector<uint64_t>* ids = nullptr);
  // Replaces every light by `lights` (fresh ids); `recipe` says how they were generated, when
  // they were with the generator's defaults. Throws 413 like addLights.
  render::LightUpdate replaceLights(std::span<const scene::PointLight> lights,
                                    std::optional<LightRecipe> recipe = std::nullopt);
  render::LightUpdate clearLights() { return replaceLights({}); }
  // Changes the members `patch` names of the light in `slot` (from slotOf).
  render::LightUpdate patchLight(uint32_t slot, const protocol::LightPatch& patch);
  // Removes the light in `slot`; the last light takes its place.
  render::LightUpdate removeLight(uint32_t slot);

  // The lights' ids in slot order and the next id to give: what a state file keeps so that a
  // session restored on another server answers to the same light ids.
  const std::vector<uint64_t>& lightIds() const { return ids_; }
  uint64_t nextLightId() const { return nextId_; }
  // Gives the lights the ids they had (CPU only: the GPU knows slots). False, changing nothing,
  // when `ids` does not fit: another count, an id twice, or one not below `next`.
  bool restoreLightIds(const std::vector<uint64_t>& ids, uint64_t next);

  // How the lights were generated, while no edit has changed them since.
  const std::optional<LightRecipe>& lightRecipe() const { return recipe_; }

  // Throws ProblemError 413 maxLightsPerSession when the session may not hold `total` lights;
  // `what` starts the detail ("This would leave the session with N lights").
  void checkLightTotal(uint64_t total, std::string_view what) const;

 private:
  // The ids/slots invariant, kept here and nowhere else: after lights_ changed, brings ids_ and
  // slotOfId_ in step and returns the GPU update. `vacated`: the light in that slot was removed
  // (the last light moves into it, keeping its id). Otherwise the lights from slot `fresh` on are
  // new and get fresh ids (0: every light is new).
  render::LightUpdate relink(uint32_t fresh, std::optional<uint32_t> vacated = std::nullopt);

  // The flat scene of the graph with the session's materials and lights; the summary follows it.
  std::shared_ptr<scene::Scene> flatten();
  // restore()'s part for a snapshot's "scene" (pointer `at`), with the assets the caller loaded.
  void restoreScene(const protocol::SnapshotScene& scene, const std::string& at,
                    const std::vector<Asset>& loaded);

  uint32_t maxLights_;
  SceneGraph graph_;
  ModelSummary model_;
  std::vector<scene::Material> materials_;
  scene::Camera camera_;
  // The camera of the session's last frame (frameSettings, under the session's lock): a motion
  // frame's previous camera, so a camera moved between two frames shows as motion; unmoved, it
  // is the camera itself.
  mutable std::optional<scene::Camera> lastFrameCamera_;
  render::SceneSettings settings_;
  bool environmentChosen_ = false;  // the client chose the environment (see adopt)
  std::shared_ptr<const scene::EnvironmentImage> environmentImage_;
  std::string environmentSource_;
  Clock::time_point animationStart_ = Clock::now();
  // The scene clock: clockSeconds_ at clockAnchor_, advancing at clockRate_ while playing.
  double clockSeconds_ = 0.0;
  Clock::time_point clockAnchor_ = Clock::now();
  bool clockPlaying_ = true;
  double clockRate_ = 1.0;

  // lights_[slot] has id ids_[slot]; slotOfId_ maps back. Kept together by the light methods.
  std::vector<scene::PointLight> lights_;
  std::vector<uint64_t> ids_;
  std::unordered_map<uint64_t, uint32_t> slotOfId_;
  uint64_t nextId_ = 1;
  std::optional<LightRecipe> recipe_;
};

}  // namespace myriad::service
