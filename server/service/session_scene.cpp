#include "service/session_scene.h"

#include <map>
#include <tuple>

#include "scene/animation.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "protocol/validate.h"
#include "scene/camera.h"
#include "scene/light_generator.h"
#include "service/problem.h"
#include "service/session_json.h"
#include "service/startup.h"
#include "service/state_store.h"

namespace myriad::service {
namespace {

void throwIfInvalid(const std::optional<protocol::ValidationError>& error) {
  if (error) throw ProblemError(invalidBody(error->pointer, error->message));
}

// A route segment's decimal id; nullopt when it is not one.
template <typename Id>
std::optional<Id> parseId(std::string_view text) {
  Id id = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return id;
}

ModelSummary summarize(const scene::Scene& scene, std::string source) {
  ModelSummary summary;
  summary.source = std::move(source);
  summary.meshes = scene.meshes.size();
  summary.instances = scene.instances.size();
  summary.materials = scene.materials.size();
  summary.bounds = scene.bounds();
  for (const scene::Image& image : scene.images) {
    summary.images.push_back({image.name, image.width, image.height});
  }
  summary.cameras = scene.cameras;
  for (const scene::PointLight& light : scene.lights) {
    (light.type == scene::LightType::Spot ? summary.spotLights : summary.pointLights) += 1;
  }
  summary.directionalLights = scene.extraSuns.size() + scene.droppedSuns;
  summary.directionalDropped = scene.droppedSuns;
  return summary;
}

}  // namespace

SessionScene::SessionScene(uint32_t maxLights, render::SceneSettings settings, uint32_t maxObjects)
    : maxLights_(maxLights), graph_(maxObjects), settings_(std::move(settings)) {}

std::string assetIdOf(std::string_view content) {
  return "a-" + sha256Hex(content).substr(0, 16);
}

// ---- The model.

std::shared_ptr<const scene::Scene> SessionScene::adopt(std::shared_ptr<scene::Scene> loaded,
                                                        std::string source, Adoption adoption) {
  using Lights = Adoption::Lights;
  Lights lights = adoption.lights;
  if (lights == Lights::automatic) lights = recipe_ ? Lights::fit : Lights::keep;
  if (lights == Lights::model) {
    checkLightTotal(loaded->lights.size(),
                    "The model brings " + std::to_string(loaded->lights.size()) + " lights");
  }
  model_ = summarize(*loaded, source);
  materials_ = loaded->materials;
  graph_.clear();
  const std::string assetId =
      adoption.assetId.empty() ? assetIdOf(source) : adoption.assetId;
  graph_.addAsset(Asset{.id = assetId, .source = source, .bytes = adoption.assetBytes,
                        .scene = loaded, .firstMaterial = 0});
  // A model of several nodes with meshes comes as its node tree of objects under one root object
  // (each part addressable and movable, its children moving with it); otherwise as one object.
  std::vector<SceneObject> tree = nodeTreeObjects(*graph_.findAsset(assetId),
                                                  graph_.nextObjectId(), source,
                                                  graph_.maxObjects());
  bool placed = false;
  if (!tree.empty()) {
    // A tree an object may not be (a node scaled to zero, a chain deeper than objects nest) is
    // refused whole, changing nothing: the model is then one object, as any other.
    try {
      graph_.addObjects(std::move(tree), uint32_t(materials_.size()), "");
      placed = true;
    } catch (const ProblemError&) {
    }
  }
  if (!placed) {
    SceneObject root;
    root.name = source;
    root.asset = assetId;
    graph_.addObjects({root}, uint32_t(materials_.size()), "");
  }
  camera_ = loaded->camera;
  if (adoption.lightingFromModel) settings_.takeLightingFrom(*loaded);
  // The model's directional lights join the sun unless the session keeps its lights as they are.
  if (lights != Lights::keep) settings_.extraSuns = loaded->extraSuns;
  // Until the environment was chosen (PATCH settings with environment.mode, a snapshot, a .hdr),
  // a loaded model is lit by the sky and the built-in scene keeps its constant ambient.
  if (!environmentChosen_) {
    settings_.environment.mode = model_.source == protocol::kBuiltinModel
                                     ? render::EnvironmentMode::None
                                     : render::EnvironmentMode::Sky;
  }
  // ?lights=model lights the model as its file does: where the file brings lights of its own,
  // they shine alone (glTF has no sun and no environment: the session's sun goes dark, and the
  // sky's or the constant ambient unless an environment was chosen), as in any glTF viewer. A
  // file without lights keeps the session's sun and sky rather than coming out black.
  const bool fileLit = !loaded->lights.empty() || !loaded->extraSuns.empty();
  if (lights == Lights::model && fileLit && !adoption.lightingFromModel) {
    settings_.sun.intensity = 0.0f;
    if (!environmentChosen_) {
      settings_.environment.mode = render::EnvironmentMode::None;
      settings_.ambient = glm::vec3(0.0f);
    }
  }
  switch (lights) {
    case Lights::model:
      lights_ = loaded->lights;
      relink(0);
      recipe_ = adoption.recipe;
      break;
    case Lights::fit: {
      const LightRecipe recipe = recipe_.value_or(LightRecipe{uint32_t(lights_.size()), 1});
      lights_ = scene::generateLights(
          defaultLightGeneration(model_.source, model_.bounds, recipe.count, recipe.seed));
      relink(0);
      recipe_ = recipe;
      loaded->lights = lights_;
      break;
    }
    case Lights::automatic:
    case Lights::keep:
      break;
  }
  return flatten();
}

std::shared_ptr<scene::Scene> SessionScene::flatten() {
  std::shared_ptr<scene::Scene> flat = graph_.flatten(materials_);
  flat->lights = lights_;
  model_.meshes = flat->meshes.size();
  model_.instances = flat->instances.size();
  model_.materials = flat->materials.size();
  model_.bounds = graph_.bounds();
  model_.images.clear();
  for (const scene::Image& image : flat->images) {
    model_.images.push_back({image.name, image.width, image.height});
  }
  return flat;
}

SessionScene::AssetAdded SessionScene::addAsset(std::shared_ptr<const scene::Scene> loaded,
                                                std::string source, std::string id,
                                                uint64_t bytes) {
  const uint32_t first = uint32_t(materials_.size());
  auto [asset, added] = graph_.addAsset(Asset{.id = std::move(id), .source = std::move(source),
                                              .bytes = bytes, .scene = loaded,
                                              .firstMaterial = first});
  AssetAdded out{asset, added, nullptr};
  if (added) {
    materials_.insert(materials_.end(), loaded->materials.begin(), loaded->materials.end());
    out.scene = flatten();
  }
  return out;
}

std::shared_ptr<const scene::Scene> SessionScene::removeAsset(std::string_view id) {
  const auto [first, count] = graph_.removeAsset(id);
  materials_.erase(materials_.begin() + first, materials_.begin() + first + count);
  return flatten();
}

std::shared_ptr<const scene::Scene> SessionScene::addObjects(std::vector<SceneObject> objects,
                                                             std::vector<uint32_t>* ids) {
  std::vector<uint32_t> added =
      graph_.addObjects(std::move(objects), uint32_t(materials_.size()), "/objects");
  if (ids != nullptr) *ids = std::move(added);
  return flatten();
}

SceneChange SessionScene::replaceObject(const SceneObject& next) {
  const SceneObject before = graph_.object(next.id);
  graph_.replaceObject(next, uint32_t(materials_.size()));
  SceneChange change;
  // The name is nobody's pixels; the semantic class is (the semantic-id label).
  const bool redraw = before.asset != next.asset || before.visible != next.visible ||
                      before.parent != next.parent || before.material != next.material ||
                      before.semantic != graph_.object(next.id).semantic ||
                      before.node != next.node || before.subtree != next.subtree;
  // A change of clip or loop needs no upload: every frame carries its pose.
  if (redraw) {
    change.scene = flatten();
  } else if (before.transform.local() != next.transform.local()) {
    change.moved = graph_.moved(next.id);
    model_.bounds = graph_.bounds();
  }
  return change;
}

std::shared_ptr<const scene::Scene> SessionScene::removeObject(uint32_t id, size_t* removed) {
  const size_t n = graph_.removeObject(id);
  if (removed != nullptr) *removed = n;
  return flatten();
}

// ---- Camera and settings.

const scene::Camera& SessionScene::setCamera(const scene::Camera& camera) {
  throwIfInvalid(protocol::checkCamera(toWire(camera)));
  camera_ = camera;
  return camera_;
}

const scene::Camera& SessionScene::patchCamera(const protocol::CameraPatch& patch) {
  scene::Camera camera = camera_;
  if (patch.eye) camera.eye = fromWire(*patch.eye);
  if (patch.target) camera.target = fromWire(*patch.target);
  if (patch.up) camera.up = fromWire(*patch.up);
  if (patch.fovY) camera.fovYDegrees = float(*patch.fovY);
  if (patch.near) camera.nearPlane = float(*patch.near);
  if (patch.far) camera.farPlane = float(*patch.far);
  return setCamera(camera);
}

const scene::Camera& SessionScene::frameModel(float aspect) {
  camera_ = scene::frameBounds(model_.bounds, camera_.eye - camera_.target, camera_.fovYDegrees,
                               aspect);
  return camera_;
}

const scene::Camera& SessionScene::selectModelCamera(uint64_t index) {
  if (index >= model_.cameras.size()) {
    throw ProblemError(invalidBody(
        "/modelCamera", "The session's model has no camera " + std::to_string(index) + " (it has " +
                            std::to_string(model_.cameras.size()) + ", model.cameras)."));
  }
  const scene::ModelCamera& c = model_.cameras[index];
  if (!c.perspective) {
    throw ProblemError(invalidBody("/modelCamera", "Model camera " + std::to_string(index) +
                                                       " is orthographic; Myriad renders "
                                                       "perspective cameras only."));
  }
  scene::Camera camera;
  camera.eye = c.position;
  // The target one model-diagonal ahead (only its direction matters for the view).
  const float reach = std::max(glm::length(model_.bounds.size()), 1.0f);
  camera.target = c.position + c.direction * (model_.bounds.empty() ? 1.0f : reach);
  camera.up = c.up;
  camera.fovYDegrees = std::clamp(glm::degrees(c.yfov), 1.0f, 179.0f);
  camera.nearPlane = c.znear;
  // glTF's infinite far plane (no zfar): far enough to hold the whole model from the camera.
  const float farthest = model_.bounds.empty()
                             ? 1000.0f
                             : glm::length(model_.bounds.center() - c.position) + 0.5f * reach;
  camera.farPlane = c.zfar > c.znear ? c.zfar : std::max(farthest * 1.01f, c.znear * 2.0f);
  return setCamera(camera);
}

const render::SceneSettings& SessionScene::patchSettings(const protocol::SettingsPatch& patch,
                                                         Clock::time_point now) {
  render::SceneSettings s = settings_;
  if (patch.sun) {
    if (patch.sun->direction) {
      throwIfInvalid(protocol::checkSunDirection(*patch.sun->direction));
      // The renderer wants a unit direction; checkSunDirection ruled out zero. One that is unit
      // already (as GET settings and snapshots give it) is kept as sent, so it reads back as it was.
      const glm::vec3 direction = fromWire(*patch.sun->direction);
      const float length = glm::length(direction);
      s.sun.direction = std::abs(length - 1.0f) <= 1e-6f ? direction : direction / length;
    }
    if (patch.sun->color) s.sun.color = fromWire(*patch.sun->color);
    if (patch.sun->intensity) s.sun.intensity = float(*patch.sun->intensity);
  }
  if (patch.suns) {
    s.extraSuns.clear();
    for (size_t i = 0; i < patch.suns->size() && i < scene::kMaxExtraSuns; ++i) {
      const protocol::Sun& sun = (*patch.suns)[i];
      if (auto error = protocol::checkSunDirection(sun.direction)) {
        throw ProblemError(invalidBody("/suns/" + std::to_string(i) + "/direction",
                                       "\"suns/" + std::to_string(i) + "/direction\" must not be [0, 0, 0]."));
      }
      scene::Sun extra;
      extra.direction = glm::normalize(fromWire(sun.direction));
      extra.color = fromWire(sun.color);
      extra.intensity = float(sun.intensity);
      s.extraSuns.push_back(extra);
    }
  }
  if (patch.ambient) s.ambient = fromWire(*patch.ambient);
  if (patch.background) s.background = fromWire(*patch.background);
  if (patch.exposure) s.exposure = float(*patch.exposure);
  if (patch.markers) s.markers = *patch.markers;
  if (patch.antialias) s.antialias = antialiasFromWire(*patch.antialias);
  if (patch.technique) s.technique = techniqueFromWire(*patch.technique);
  if (patch.animate) s.animate = *patch.animate;
  if (patch.environment) {
    const protocol::EnvironmentPatch& e = *patch.environment;
    if (e.mode) {
      s.environment.mode = environmentModeFromWire(*e.mode);
      if (s.environment.mode == render::EnvironmentMode::Hdr && !environmentImage_) {
        throw ProblemError(invalidBody(
            "/environment/mode",
            "The environment mode \"hdr\" needs an equirectangular .hdr: upload one first (PUT "
            ".../environment), which also selects it."));
      }
    }
    if (e.intensity) s.environment.intensity = float(*e.intensity);
    if (e.rotation) s.environment.rotation = float(*e.rotation);
    if (e.background) s.environment.background = *e.background;
  }
  if (patch.shadows) {
    // The schema allows only render::kShadowMapSizes.
    if (patch.shadows->sun) s.shadows.sun = *patch.shadows->sun;
    if (patch.shadows->mapSize) s.shadows.mapSize = *patch.shadows->mapSize;
    // The schema bounds it to 0..render::kMaxShadowedLights.
    if (patch.shadows->maxShadowedLights) {
      s.shadows.maxShadowedLights = std::min(*patch.shadows->maxShadowedLights, render::kMaxShadowedLights);
    }
    if (patch.shadows->local) s.shadows.local = localShadowsFromWire(*patch.shadows->local);
    // The schema bounds it to 1..render::kMaxSunCascades.
    if (patch.shadows->cascades) {
      s.shadows.cascades = std::clamp(*patch.shadows->cascades, 1u, render::kMaxSunCascades);
    }
  }
  if (patch.fog) {
    if (patch.fog->density) {
      // The schema bounds it; checked again for a caller that skipped it (a NaN would fog every
      // surface to NaN).
      const double density = *patch.fog->density;
      if (!(density >= 0.0 && density <= render::kMaxFogDensity)) {
        throw ProblemError(invalidBody("/fog/density", "\"density\" must be from 0 to 10 (per metre)."));
      }
      s.fog.density = float(density);
    }
    if (patch.fog->color) s.fog.color = fromWire(*patch.fog->color);
  }
  if (s.animate && !settings_.animate) animationStart_ = now;
  if (patch.environment && patch.environment->mode) environmentChosen_ = true;
  settings_ = s;
  return settings_;
}

void SessionScene::setEnvironmentImage(std::shared_ptr<const scene::EnvironmentImage> image,
                                       std::string source) {
  environmentImage_ = std::move(image);
  environmentSource_ = std::move(source);
  settings_.environment.mode = render::EnvironmentMode::Hdr;
  environmentChosen_ = true;
}

double SessionScene::animationSeconds(Clock::time_point now) const {
  if (!settings_.animate) return 0.0;
  return std::chrono::duration<double>(now - animationStart_).count();
}

render::FrameSettings SessionScene::frameSettings(const render::FrameSettings& request,
                                                  std::optional<double> time,
                                                  Clock::time_point now) const {
  render::FrameSettings frame = request;
  static_cast<render::SceneSettings&>(frame) = settings_;
  frame.camera = camera_;
  frame.animate = settings_.animate || time.has_value();
  frame.time = time.value_or(animationSeconds(now));
  // The objects' pose: at ?time= exactly when given, else where the scene clock is.
  frame.pose = poseAt(time.value_or(clockSeconds(now)));
  if (frame.target == render::Target::Motion) {
    // The motion target's previous time, render::kMotionInterval earlier (not before 0): the pose
    // then, so ?time=T's motion is exact and the same on every call; the previous frame's camera.
    const double t = time.value_or(clock(now).time);
    frame.previousPose = poseAt(std::max(0.0, t - render::kMotionInterval));
    frame.previousCamera = lastFrameCamera_.value_or(camera_);
  }
  lastFrameCamera_ = camera_;
  return frame;
}

// ---- The scene clock and poses.

double SessionScene::clockSeconds(Clock::time_point now) const {
  double t = clockSeconds_;
  if (clockPlaying_) t += clockRate_ * std::chrono::duration<double>(now - clockAnchor_).count();
  // Kept within what a frame's ?time= accepts, whatever the rate and uptime.
  return std::clamp(t, 0.0, protocol::query::kMaxFrameTime);
}

SessionScene::SceneClock SessionScene::clock(Clock::time_point now) const {
  SceneClock out;
  out.playing = clockPlaying_;
  out.rate = clockRate_;
  out.time = clockSeconds(now);
  std::unordered_map<std::string_view, const Asset*> withClips;
  for (const Asset& a : graph_.assets()) {
    if (!a.scene->animations.empty()) withClips.emplace(a.id, &a);
  }
  if (withClips.empty()) return out;
  for (const auto& [id, o] : graph_.objects()) {
    const auto found = withClips.find(o.asset);
    if (found == withClips.end() || o.clip < 0 || !graph_.shown(id)) continue;
    const auto& clips = found->second->scene->animations;
    if (size_t(o.clip) < clips.size()) {
      out.duration = std::max(out.duration, double(clips[size_t(o.clip)].duration));
    }
  }
  return out;
}

SessionScene::SceneClock SessionScene::patchClock(std::optional<bool> playing,
                                                  std::optional<double> time,
                                                  std::optional<double> rate,
                                                  Clock::time_point now) {
  // Re-anchored at now first, so a change of rate or a pause keeps the time it reached.
  clockSeconds_ = clockSeconds(now);
  clockAnchor_ = now;
  if (time) clockSeconds_ = *time;
  if (rate) clockRate_ = *rate;
  if (playing) clockPlaying_ = *playing;
  return clock(now);
}

bool SessionScene::moving() const {
  return settings_.animate || (clockPlaying_ && clockRate_ != 0.0 && graph_.playing());
}

std::shared_ptr<const render::ScenePose> SessionScene::poseAt(double seconds) const {
  std::shared_ptr<render::ScenePose> pose;
  // Most scenes have nothing to pose: one look at the assets, not at every object.
  std::unordered_map<std::string_view, const Asset*> animatedAssets;
  for (const Asset& a : graph_.assets()) {
    if (a.animated) animatedAssets.emplace(a.id, &a);
  }
  if (animatedAssets.empty()) return pose;
  // Objects of one asset playing one clip the same way share one evaluation.
  std::map<std::tuple<const Asset*, int32_t, bool>, std::vector<scene::PosedInstance>> evaluated;
  for (const auto& [id, o] : graph_.objects()) {
    const auto found = animatedAssets.find(o.asset);
    if (found == animatedAssets.end()) continue;
    const Asset* a = found->second;
    const SceneGraph::Placement* placement = graph_.placement(id);
    if (placement == nullptr || placement->count == 0) continue;
    if (!pose) {
      pose = std::make_shared<render::ScenePose>();
      pose->time = seconds;
    }
    const int32_t clip = o.clip < int32_t(a->scene->animations.size()) ? o.clip : -1;
    const auto key = std::make_tuple(a, clip, o.loop);
    auto it = evaluated.find(key);
    if (it == evaluated.end()) {
      it = evaluated.emplace(key, scene::poseInstances(*a->scene, clip, seconds, o.loop)).first;
    }
    std::optional<glm::mat4> world;
    const std::vector<uint32_t>& subset = placement->assetInstances;  // a node object's
    for (const scene::PosedInstance& posed : it->second) {
      uint32_t offset = posed.instance;
      if (!subset.empty()) {
        const auto at = std::lower_bound(subset.begin(), subset.end(), posed.instance);
        if (at == subset.end() || *at != posed.instance) continue;
        offset = uint32_t(at - subset.begin());
      }
      if (offset >= placement->count) continue;
      const uint32_t flat = placement->first + offset;
      if (posed.transform) {
        if (!world) world = graph_.worldOf(id) * placement->fromNode;
        const glm::mat4 placed = *world * *posed.transform;
        // An object's scale times a node's can overflow: that instance keeps its last place.
        bool finite = true;
        for (int c = 0; c < 4; ++c) {
          for (int r = 0; r < 4; ++r) finite = finite && std::isfinite(placed[c][r]);
        }
        if (finite) pose->transforms.push_back({flat, placed});
      }
      if (!posed.joints.empty() || !posed.morphWeights.empty()) {
        pose->poses.push_back({flat, posed.joints, posed.morphWeights});
      }
    }
  }
  return pose;
}

// ---- Snapshots.

std::vector<protocol::SemanticClass> SessionScene::semanticClasses() const {
  std::vector<protocol::SemanticClass> out;
  out.reserve(graph_.classes().size());
  for (const auto& [name, id] : graph_.classes()) out.push_back({name, id});
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

protocol::Snapshot SessionScene::snapshot() const {
  protocol::Snapshot out;
  out.model.source = model_.source;
  out.camera = toWire(camera_);
  out.settings = toWire(settings_);
  if (environmentImage_) out.settings.environment.source = environmentSource_;
  protocol::SnapshotScene& scene = out.scene.emplace();
  for (const Asset& a : graph_.assets()) scene.assets.push_back({a.id, a.source});
  for (const auto& [id, o] : graph_.objects()) scene.objects.push_back(toWire(*this, o));
  scene.nextObjectId = graph_.nextObjectId();
  scene.classes = semanticClasses();
  out.materials.reserve(materials_.size());
  for (uint32_t id = 0; id < materials_.size(); ++id) out.materials.push_back(toWire(id, materials_[id], model_.images));
  if (recipe_) {
    out.lights.generated = protocol::LightsRecipe{recipe_->count, recipe_->seed};
  } else {
    std::vector<protocol::LightNew>& list = out.lights.list.emplace();
    list.reserve(lights_.size());
    for (const scene::PointLight& light : lights_) list.push_back(toWireNew(light));
  }
  return out;
}

SessionScene::Restored SessionScene::restore(const protocol::Snapshot& snapshot,
                                             std::string_view pointer, Clock::time_point now,
                                             const SnapshotLoads& image) {
  const std::string at(pointer);
  // Checks and changes a copy, so that a refusal anywhere leaves this scene as it was.
  SessionScene next = *this;
  Restored restored;
  try {
    next.setCamera(fromWire(snapshot.camera));
  } catch (const ProblemError& e) {
    throw ProblemError(invalidBody(at + "/camera" + e.problem().pointer.value_or(""), e.problem().detail));
  }
  protocol::SettingsPatch settings;
  settings.sun = protocol::SunPatch{snapshot.settings.sun.direction, snapshot.settings.sun.color,
                                    snapshot.settings.sun.intensity};
  settings.suns = snapshot.settings.suns;
  settings.ambient = snapshot.settings.ambient;
  settings.background = snapshot.settings.background;
  settings.exposure = snapshot.settings.exposure;
  settings.markers = snapshot.settings.markers;
  // A snapshot from before anti-aliasing existed restores it as a new session has it.
  settings.antialias =
      snapshot.settings.antialias.value_or(std::string(protocol::antialias_modes::kFxaa));
  settings.technique = snapshot.settings.technique;
  settings.animate = snapshot.settings.animate;
  const protocol::Environment& environment = snapshot.settings.environment;
  if (image.image) next.setEnvironmentImage(image.image, image.source);
  settings.environment = protocol::EnvironmentPatch{environment.mode, environment.intensity,
                                                    environment.rotation, environment.background};
  settings.shadows = protocol::ShadowsPatch{
      snapshot.settings.shadows.sun, snapshot.settings.shadows.mapSize,
      snapshot.settings.shadows.maxShadowedLights.value_or(render::kDefaultShadowedLights),
      snapshot.settings.shadows.local.value_or(std::string(protocol::local_shadow_modes::kMaps)),
      snapshot.settings.shadows.cascades.value_or(render::kDefaultSunCascades)};
  // A snapshot from before fog reads as fog off (protocol::Fog's default).
  settings.fog = protocol::FogPatch{snapshot.settings.fog.density, snapshot.settings.fog.color};
  try {
    next.patchSettings(settings, now);
  } catch (const ProblemError& e) {
    throw ProblemError(invalidBody(at + "/settings" + e.problem().pointer.value_or(""), e.problem().detail));
  }
  if (snapshot.scene) next.restoreScene(*snapshot.scene, at + "/scene", image.assets);
  for (size_t i = 0; i < snapshot.materials.size(); ++i) {
    const protocol::Material& m = snapshot.materials[i];
    if (m.id >= next.materials_.size()) {
      throw ProblemError(invalidBody(
          at + "/materials/" + std::to_string(i) + "/id",
          "The session's model has no material " + std::to_string(m.id) + " (it has " +
              std::to_string(next.materials_.size()) + "): a snapshot restores onto its own model."));
    }
    // The layers, ior and specular a snapshot from before they could be edited leaves out are
    // the model file's (what the session had then).
    const scene::Material& loaded = next.loadedMaterial(m.id);
    const protocol::MaterialPatch patch{
        m.baseColor,
        m.metallic,
        m.roughness,
        m.alpha,
        m.emissive,
        m.emissiveStrength,
        m.normalScale,
        m.occlusionStrength,
        m.alphaMode,
        m.alphaCutoff,
        m.doubleSided,
        m.clearcoat.value_or(loaded.clearcoat),
        m.clearcoatRoughness.value_or(loaded.clearcoatRoughness),
        m.sheenColor.value_or(toWire(loaded.sheenColor)),
        m.sheenRoughness.value_or(loaded.sheenRoughness),
        m.ior.value_or(loaded.ior),
        m.specular.value_or(loaded.specular)};
    try {
      restored.materials.push_back(next.patchMaterial(m.id, patch));
    } catch (const ProblemError& e) {
      throw ProblemError(invalidBody(at + "/materials/" + std::to_string(i) +
                                         e.problem().pointer.value_or(""),
                                     e.problem().detail));
    }
  }
  const protocol::SnapshotLights& lights = snapshot.lights;
  if (lights.generated.has_value() == lights.list.has_value()) {
    throw ProblemError(invalidBody(at + "/lights",
                                   "\"lights\" holds exactly one of \"generated\" and \"list\"."));
  }
  if (lights.generated) {
    next.checkLightTotal(lights.generated->count, "This would leave the session with " +
                                                      std::to_string(lights.generated->count) +
                                                      " lights");
    const LightRecipe recipe{uint32_t(lights.generated->count), lights.generated->seed};
    const std::vector<scene::PointLight> generated = scene::generateLights(
        defaultLightGeneration(next.model_.source, next.model_.bounds, recipe.count, recipe.seed));
    restored.lights = next.replaceLights(generated, recipe);
  } else {
    std::vector<scene::PointLight> list;
    list.reserve(lights.list->size());
    for (size_t i = 0; i < lights.list->size(); ++i) {
      list.push_back(fromWire((*lights.list)[i], at + "/lights/list/" + std::to_string(i)));
    }
    restored.lights = next.replaceLights(list);
  }
  if (snapshot.scene) restored.scene = next.flatten();
  *this = std::move(next);
  return restored;
}

void SessionScene::restoreScene(const protocol::SnapshotScene& scene, const std::string& at,
                                const std::vector<Asset>& loaded) {
  // The assets in the snapshot's order, each the session's own (with its edited materials) or
  // one the caller loaded; their materials in the same order.
  std::vector<Asset> assets;
  std::vector<scene::Material> materials;
  for (size_t i = 0; i < scene.assets.size(); ++i) {
    const std::string& id = scene.assets[i].id;
    const std::string& source = scene.assets[i].source;
    Asset asset;
    const scene::Material* first = nullptr;
    if (const Asset* have = graph_.findAsset(id)) {
      asset = *have;
      first = materials_.data() + have->firstMaterial;
    } else {
      const auto it = std::find_if(loaded.begin(), loaded.end(),
                                   [&](const Asset& a) { return a.id == id; });
      if (it == loaded.end()) {
        throw ProblemError(invalidBody(
            at + "/assets/" + std::to_string(i) + "/id",
            "The session has no asset " + quoteClientText(id) + " (" + quoteClientText(source) +
                "): upload it first (POST .../assets), then restore the snapshot."));
      }
      asset = *it;
      // What SceneGraph::addAsset works out for an asset it takes.
      asset.bounds = asset.scene->bounds();
      asset.animated = scene::animated(*asset.scene);
      first = asset.scene->materials.data();
    }
    if (std::any_of(assets.begin(), assets.end(), [&](const Asset& a) { return a.id == id; })) {
      throw ProblemError(invalidBody(at + "/assets/" + std::to_string(i) + "/id",
                                     "The asset " + quoteClientText(id) + " is listed twice."));
    }
    asset.firstMaterial = uint32_t(materials.size());
    materials.insert(materials.end(), first, first + asset.scene->materials.size());
    assets.push_back(std::move(asset));
  }
  std::vector<SceneObject> objects;
  objects.reserve(scene.objects.size());
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const protocol::Object& wire = scene.objects[i];
    SceneObject o;
    o.id = uint32_t(wire.id);  // the schema bounds ids to uint32
    try {
      applyObjectPatch(
          {wire.name, wire.asset, wire.transform, wire.visible, wire.parent, wire.material,
           wire.semantic, wire.animation, protocol::Nullable<uint64_t>{wire.node}, std::nullopt,
           wire.subtree},
          o);
    } catch (const ProblemError& e) {
      throw ProblemError(invalidBody(at + "/objects/" + std::to_string(i) +
                                         e.problem().pointer.value_or(""),
                                     e.problem().detail));
    }
    objects.push_back(std::move(o));
  }
  SceneGraph graph = graph_;
  graph.replaceAssets(std::move(assets));
  std::vector<std::pair<std::string, uint32_t>> classes;
  if (scene.classes) {
    for (const protocol::SemanticClass& c : *scene.classes) {
      classes.emplace_back(c.name, uint32_t(c.id));  // the schema bounds ids to 1..65535
    }
  }
  graph.restoreObjects(std::move(objects), uint32_t(scene.nextObjectId),
                       uint32_t(materials.size()), at + "/objects", classes, at + "/classes");
  graph_ = std::move(graph);
  materials_ = std::move(materials);
}

// ---- Materials.

const scene::Material& SessionScene::loadedMaterial(uint32_t id) const {
  for (const Asset& a : graph_.assets()) {
    if (id >= a.firstMaterial && id - a.firstMaterial < a.scene->materials.size()) {
      return a.scene->materials[id - a.firstMaterial];
    }
  }
  return materials_.at(id);  // (every material is an asset's)
}

uint32_t SessionScene::materialId(std::string_view text) const {
  std::optional<uint32_t> id = parseId<uint32_t>(text);
  if (!id || *id >= materials_.size()) {
    throw ProblemError(notFoundDetail("The session's model has no material " +
                                      quoteClientText(text) + " (it has " +
                                      std::to_string(materials_.size()) + ", ids from 0)."));
  }
  return *id;
}

render::MaterialWrite SessionScene::patchMaterial(uint32_t id,
                                                  const protocol::MaterialPatch& patch) {
  scene::Material& material = materials_.at(id);
  if (patch.baseColor) material.baseColor = fromWire(*patch.baseColor);
  if (patch.metallic) material.metallic = float(*patch.metallic);
  if (patch.roughness) material.roughness = float(*patch.roughness);
  if (patch.alpha) material.alpha = float(*patch.alpha);
  if (patch.emissive) material.emissive = fromWire(*patch.emissive);
  if (patch.emissiveStrength) material.emissiveStrength = float(*patch.emissiveStrength);
  if (patch.normalScale) material.normalScale = float(*patch.normalScale);
  if (patch.occlusionStrength) material.occlusionStrength = float(*patch.occlusionStrength);
  if (patch.alphaMode) material.alphaMode = alphaModeFromWire(*patch.alphaMode);
  if (patch.alphaCutoff) material.alphaCutoff = float(*patch.alphaCutoff);
  if (patch.doubleSided) material.doubleSided = *patch.doubleSided;
  if (patch.clearcoat) material.clearcoat = float(*patch.clearcoat);
  if (patch.clearcoatRoughness) material.clearcoatRoughness = float(*patch.clearcoatRoughness);
  if (patch.sheenColor) material.sheenColor = fromWire(*patch.sheenColor);
  if (patch.sheenRoughness) material.sheenRoughness = float(*patch.sheenRoughness);
  if (patch.ior) material.ior = float(*patch.ior);
  if (patch.specular) material.specular = float(*patch.specular);
  return render::MaterialWrite{id, material};
}

// ---- Lights.

uint32_t SessionScene::slotOf(std::string_view text) const {
  std::optional<uint64_t> id = parseId<uint64_t>(text);
  auto it = id ? slotOfId_.find(*id) : slotOfId_.end();
  if (it == slotOfId_.end()) {
    throw ProblemError(notFoundDetail("The session has no light " + quoteClientText(text) +
                                      " (deleted, or never created)."));
  }
  return it->second;
}

void SessionScene::checkLightTotal(uint64_t total, std::string_view what) const {
  if (total > maxLights_) {
    throw ProblemError(limitExceeded(413, "maxLightsPerSession",
                                     std::string(what) + "; a session holds at most " +
                                         std::to_string(maxLights_) + "."));
  }
}

bool SessionScene::restoreLightIds(const std::vector<uint64_t>& ids, uint64_t next) {
  if (ids.size() != lights_.size()) return false;
  std::unordered_map<uint64_t, uint32_t> slots;
  slots.reserve(ids.size());
  for (uint32_t slot = 0; slot < ids.size(); ++slot) {
    if (ids[slot] == 0 || ids[slot] >= next || !slots.emplace(ids[slot], slot).second) return false;
  }
  ids_ = ids;
  slotOfId_ = std::move(slots);
  nextId_ = next;
  return true;
}

render::LightUpdate SessionScene::relink(uint32_t fresh, std::optional<uint32_t> vacated) {
  render::LightUpdate update;
  if (vacated) {
    // A swap-remove: the last light (and its id) moves into the vacated slot.
    const uint32_t slot = *vacated;
    const auto last = uint32_t(lights_.size() - 1);
    slotOfId_.erase(ids_.at(slot));
    if (slot != last) {
      lights_[slot] = lights_[last];
      ids_[slot] = ids_[last];
      slotOfId_[ids_[slot]] = slot;
      update.writes.push_back(render::LightWrite{slot, lights_[slot]});
    }
    lights_.pop_back();
    ids_.pop_back();
    fresh = uint32_t(lights_.size());
  }
  // Lights from slot `fresh` on are new: fresh ids (never reused), each written.
  if (fresh == 0) slotOfId_.clear();
  for (uint32_t slot = fresh; slot < ids_.size(); ++slot) slotOfId_.erase(ids_[slot]);
  ids_.resize(fresh);
  ids_.reserve(lights_.size());
  slotOfId_.reserve(lights_.size());
  update.writes.reserve(update.writes.size() + (lights_.size() - fresh));
  for (uint32_t slot = fresh; slot < lights_.size(); ++slot) {
    const uint64_t id = nextId_++;
    ids_.push_back(id);
    slotOfId_.emplace(id, slot);
    update.writes.push_back(render::LightWrite{slot, lights_[slot]});
  }
  update.count = uint32_t(lights_.size());
  return update;
}

render::LightUpdate SessionScene::addLights(std::span<const scene::PointLight> lights,
                                            std::vector<uint64_t>* ids) {
  const uint64_t total = uint64_t(lights_.size()) + lights.size();
  checkLightTotal(total, "This would leave the session with " + std::to_string(total) + " lights");
  recipe_.reset();
  const auto first = uint32_t(lights_.size());
  lights_.insert(lights_.end(), lights.begin(), lights.end());
  render::LightUpdate update = relink(first);
  if (ids != nullptr) ids->insert(ids->end(), ids_.begin() + first, ids_.end());
  return update;
}

render::LightUpdate SessionScene::replaceLights(std::span<const scene::PointLight> lights,
                                                std::optional<LightRecipe> recipe) {
  checkLightTotal(lights.size(),
                  "This would leave the session with " + std::to_string(lights.size()) + " lights");
  lights_.assign(lights.begin(), lights.end());
  recipe_ = recipe;
  return relink(0);
}

render::LightUpdate SessionScene::patchLight(uint32_t slot, const protocol::LightPatch& patch) {
  // The patched light is checked whole (a cone made inverted by either angle is refused) before
  // anything changes.
  const bool blameOuter = patch.outerConeAngle.has_value() && !patch.innerConeAngle.has_value();
  const scene::PointLight patched =
      fromWire(protocol::applied(toWire(0, lights_.at(slot)), patch), "", blameOuter);
  recipe_.reset();
  lights_[slot] = patched;
  return render::LightUpdate{uint32_t(lights_.size()), {render::LightWrite{slot, patched}}};
}

render::LightUpdate SessionScene::removeLight(uint32_t slot) {
  recipe_.reset();
  return relink(0, slot);
}

}  // namespace myriad::service
