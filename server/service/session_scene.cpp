#include "service/session_scene.h"

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
  SceneObject root;
  root.name = source;
  root.asset = assetId;
  graph_.addObjects({root}, uint32_t(materials_.size()), "");
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
  switch (lights) {
    case Lights::model:
      lights_ = loaded->lights;
      relink(0);
      recipe_ = adoption.recipe;
      break;
    case Lights::fit: {
      const LightRecipe recipe = recipe_.value_or(LightRecipe{uint32_t(lights_.size()), 1});
      lights_ = scene::generateLights(lightGenerationAround(model_.bounds, recipe.count, recipe.seed));
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
                      before.semantic != next.semantic;
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
  return frame;
}

// ---- Snapshots.

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
      snapshot.settings.shadows.maxShadowedLights.value_or(render::kDefaultShadowedLights)};
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
    const protocol::MaterialPatch patch{m.baseColor,        m.metallic,    m.roughness,
                                        m.alpha,            m.emissive,    m.emissiveStrength,
                                        m.normalScale,      m.occlusionStrength, m.alphaMode,
                                        m.alphaCutoff,      m.doubleSided};
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
        lightGenerationAround(next.model_.bounds, recipe.count, recipe.seed));
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
      applyObjectPatch({wire.name, wire.asset, wire.transform, wire.visible, wire.parent,
                        wire.material, wire.semantic},
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
  graph.restoreObjects(std::move(objects), uint32_t(scene.nextObjectId),
                       uint32_t(materials.size()), at + "/objects");
  graph_ = std::move(graph);
  materials_ = std::move(materials);
}

// ---- Materials.

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
