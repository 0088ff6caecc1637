#include "service/session_json.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include "protocol/validate.h"
#include "service/problem.h"

namespace myriad::service {
namespace {

// The double whose shortest decimal form is the float's: 0.1f goes out as 0.1, not as
// 0.10000000149011612 (what the float holds exactly), so values read back as they were sent.
double wire(float value) {
  char text[32];
  auto [end, ec] = std::to_chars(text, text + sizeof text - 1, value);
  if (ec != std::errc()) return value;
  *end = '\0';
  return std::strtod(text, nullptr);
}

}  // namespace

protocol::Vec3 toWire(const glm::vec3& v) { return {wire(v.x), wire(v.y), wire(v.z)}; }

glm::vec3 fromWire(const protocol::Vec3& v) {
  return glm::vec3(float(v[0]), float(v[1]), float(v[2]));
}

protocol::Camera toWire(const scene::Camera& c) {
  protocol::Camera out;
  out.eye = toWire(c.eye);
  out.target = toWire(c.target);
  out.up = toWire(c.up);
  out.fovY = wire(c.fovYDegrees);
  out.near = wire(c.nearPlane);
  out.far = wire(c.farPlane);
  return out;
}

scene::Camera fromWire(const protocol::Camera& c) {
  scene::Camera out;
  out.eye = fromWire(c.eye);
  out.target = fromWire(c.target);
  out.up = fromWire(c.up);
  out.fovYDegrees = float(c.fovY);
  out.nearPlane = float(c.near);
  out.farPlane = float(c.far);
  return out;
}

protocol::Settings toWire(const render::SceneSettings& s) {
  protocol::Settings out;
  out.sun.direction = toWire(s.sun.direction);
  out.sun.color = toWire(s.sun.color);
  out.sun.intensity = wire(s.sun.intensity);
  for (const scene::Sun& sun : s.extraSuns) {
    out.suns.push_back(protocol::Sun{toWire(sun.direction), toWire(sun.color), wire(sun.intensity)});
  }
  out.ambient = toWire(s.ambient);
  out.exposure = wire(s.exposure);
  out.markers = s.markers;
  out.antialias = std::string(render::antialiasName(s.antialias));
  out.technique = std::string(render::techniqueName(s.technique));
  out.animate = s.animate;
  out.background = toWire(s.background);
  out.environment.mode = std::string(render::environmentModeName(s.environment.mode));
  out.environment.intensity = wire(s.environment.intensity);
  out.environment.rotation = wire(s.environment.rotation);
  out.environment.background = s.environment.background;
  out.shadows.sun = s.shadows.sun;
  out.shadows.mapSize = s.shadows.mapSize;
  out.shadows.maxShadowedLights = s.shadows.maxShadowedLights;
  out.shadows.local = std::string(render::localShadowsName(s.shadows.local));
  out.shadows.cascades = s.shadows.cascades;
  out.fog.density = wire(s.fog.density);
  out.fog.color = toWire(s.fog.color);
  return out;
}

protocol::Settings toWire(const SessionScene& scene) {
  protocol::Settings out = toWire(scene.settings());
  if (scene.environmentImage()) out.environment.source = scene.environmentSource();
  return out;
}

render::EnvironmentMode environmentModeFromWire(std::string_view name) {
  std::optional<render::EnvironmentMode> mode = render::parseEnvironmentMode(name);
  if (!mode) {
    throw ProblemError(invalidBody("/environment/mode", "\"mode\" must be none, sky or hdr."));
  }
  return *mode;
}

render::Antialias antialiasFromWire(std::string_view name) {
  std::optional<render::Antialias> mode = render::parseAntialias(name);
  if (!mode) throw ProblemError(invalidBody("/antialias", "\"antialias\" must be none, fxaa, taa or ssaa."));
  return *mode;
}

render::LocalShadows localShadowsFromWire(std::string_view name) {
  std::optional<render::LocalShadows> mode = render::parseLocalShadows(name);
  if (!mode) {
    throw ProblemError(
        invalidBody("/shadows/local", "\"local\" must be none, maps or stochastic."));
  }
  return *mode;
}

render::Technique techniqueFromWire(std::string_view name) {
  std::optional<render::Technique> technique = render::parseTechnique(name);
  if (!technique) {
    throw ProblemError(
        invalidBody("/technique", "\"technique\" must be " + render::techniqueChoices() + "."));
  }
  return *technique;
}

protocol::Material toWire(uint32_t id, const scene::Material& m,
                          const std::vector<ModelSummary::Image>& images) {
  protocol::Material out;
  out.id = id;
  out.name = m.name;
  out.baseColor = toWire(m.baseColor);
  out.metallic = wire(m.metallic);
  out.roughness = wire(m.roughness);
  out.alpha = wire(m.alpha);
  out.emissive = toWire(m.emissive);
  out.emissiveStrength = wire(m.emissiveStrength);
  out.normalScale = wire(m.normalScale);
  out.occlusionStrength = wire(m.occlusionStrength);
  out.alphaMode = std::string(protocol::kAlphaModes[size_t(m.alphaMode)]);
  out.alphaCutoff = wire(m.alphaCutoff);
  out.doubleSided = m.doubleSided;
  out.clearcoat = wire(m.clearcoat);
  out.clearcoatRoughness = wire(m.clearcoatRoughness);
  out.sheenColor = toWire(m.sheenColor);
  out.sheenRoughness = wire(m.sheenRoughness);
  out.ior = wire(m.ior);
  out.specular = wire(m.specular);
  for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
    const scene::TextureRef& t = m.texture(slot);
    if (!t.present() || t.image >= images.size()) continue;
    protocol::MaterialTexture texture;
    texture.slot = std::string(protocol::kTextureSlots[slot]);
    texture.image = images[t.image].name;
    texture.width = images[t.image].width;
    texture.height = images[t.image].height;
    texture.wrapS = std::string(protocol::kWrapModes[size_t(t.sampler.wrapS)]);
    texture.wrapT = std::string(protocol::kWrapModes[size_t(t.sampler.wrapT)]);
    texture.magFilter = std::string(protocol::kFilters[size_t(t.sampler.magFilter)]);
    texture.minFilter = std::string(protocol::kFilters[size_t(t.sampler.minFilter)]);
    texture.mipmaps = t.sampler.mipmaps;
    out.textures.push_back(std::move(texture));
  }
  return out;
}

scene::AlphaMode alphaModeFromWire(std::string_view name) {
  for (size_t i = 0; i < protocol::kAlphaModes.size(); ++i) {
    if (protocol::kAlphaModes[i] == name) return scene::AlphaMode(i);
  }
  throw ProblemError(invalidBody("/alphaMode", "\"alphaMode\" must be one of opaque, mask, blend."));
}

protocol::LightNew toWireNew(const scene::PointLight& l) {
  protocol::LightNew out;
  out.position = toWire(l.position);
  out.radius = wire(l.radius);
  out.color = toWire(l.color);
  out.intensity = wire(l.intensity);
  out.falloff = wire(l.falloff);
  out.type = std::string(l.type == scene::LightType::Spot ? protocol::light_types::kSpot
                                                          : protocol::light_types::kPoint);
  out.attenuation = std::string(l.attenuation == scene::Attenuation::InverseSquare
                                    ? protocol::attenuations::kInverseSquare
                                    : protocol::attenuations::kWindow);
  out.direction = toWire(l.direction);
  out.innerConeAngle = wire(l.innerConeAngle);
  out.outerConeAngle = wire(l.outerConeAngle);
  out.castsShadows = l.castsShadows;
  return out;
}

protocol::Light toWire(uint64_t id, const scene::PointLight& l) {
  return protocol::withId(toWireNew(l), id);
}

scene::PointLight fromWire(const protocol::Light& l, std::string_view pointer, bool blameOuter) {
  if (auto error = protocol::checkLight(l, blameOuter)) {
    throw ProblemError(invalidBody(std::string(pointer) + error->pointer, error->message));
  }
  scene::PointLight out;
  out.position = fromWire(l.position);
  out.radius = float(l.radius);
  out.color = fromWire(l.color);
  out.intensity = float(l.intensity);
  out.falloff = float(l.falloff);
  out.type = l.type == protocol::light_types::kSpot ? scene::LightType::Spot : scene::LightType::Point;
  out.attenuation = l.attenuation == protocol::attenuations::kInverseSquare
                        ? scene::Attenuation::InverseSquare
                        : scene::Attenuation::Window;
  // Checked non-zero (protocol::checkLight); stored as a unit vector.
  out.direction = glm::normalize(glm::vec3(fromWire(l.direction)));
  // As floats, pi/2 rounds up past the schema's maximum and inner may round onto outer: the
  // cone stays within (0, pi/2] and inner < outer.
  out.outerConeAngle =
      std::clamp(float(l.outerConeAngle), std::nextafter(0.0f, 1.0f), scene::kMaxConeAngle);
  out.innerConeAngle = std::min(float(l.innerConeAngle), std::nextafter(out.outerConeAngle, 0.0f));
  out.castsShadows = l.castsShadows.value_or(false);
  return out;
}

scene::PointLight fromWire(const protocol::LightNew& l, std::string_view pointer) {
  return fromWire(protocol::withId(l, 0), pointer);
}

protocol::Bounds toWire(const scene::Bounds& b) {
  // An empty model has no bounds; report a point at the origin rather than +-FLT_MAX.
  if (b.empty()) return protocol::Bounds{};
  return protocol::Bounds{toWire(b.min), toWire(b.max)};
}

scene::Bounds fromWire(const protocol::Bounds& b) {
  scene::Bounds out;
  out.min = fromWire(b.min);
  out.max = fromWire(b.max);
  return out;
}

protocol::SessionState stateOf(const Session& session, int64_t expiresInSeconds) {
  const SessionScene& scene = session.scene;
  protocol::SessionState state;
  state.id = session.id;
  state.model.source = scene.model().source;
  state.model.meshes = scene.model().meshes;
  state.model.instances = scene.model().instances;
  state.model.materials = scene.model().materials;
  state.model.bounds = toWire(scene.model().bounds);
  const ModelSummary& model = scene.model();
  for (size_t i = 0; i < model.cameras.size(); ++i) {
    const scene::ModelCamera& c = model.cameras[i];
    protocol::ModelCamera out;
    out.index = i;
    out.name = c.name;
    out.type = c.perspective ? "perspective" : "orthographic";
    out.yfov = wire(c.yfov);
    if (c.aspectRatio > 0.0f) out.aspectRatio = wire(c.aspectRatio);
    out.znear = wire(c.znear);
    if (c.zfar > 0.0f) out.zfar = wire(c.zfar);
    out.position = toWire(c.position);
    out.direction = toWire(c.direction);
    out.up = toWire(c.up);
    state.model.cameras.push_back(std::move(out));
  }
  state.model.lights = protocol::ModelLights{model.pointLights, model.spotLights,
                                             model.directionalLights, model.directionalDropped};
  // The model's asset (the first of its source; gone when the scene API removed it) says which
  // of the file's glTF extensions were ignored.
  for (const Asset& asset : scene.graph().assets()) {
    if (asset.source != model.source || !asset.scene) continue;
    if (!asset.scene->ignoredExtensions.empty()) {
      state.model.ignoredExtensions = asset.scene->ignoredExtensions;
    }
    break;
  }
  state.camera = toWire(scene.camera());
  state.settings = toWire(scene);
  state.lightCount = scene.lightCount();
  state.expiresInSeconds = uint64_t(std::max<int64_t>(0, expiresInSeconds));
  return state;
}

// ---- Scenes: objects and assets.

namespace {

// The world box of `box` (in some space) moved by `m`: the box of its eight corners.
scene::Bounds movedBox(const scene::Bounds& box, const glm::mat4& m) {
  scene::Bounds out;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p((corner & 1) ? box.max.x : box.min.x, (corner & 2) ? box.max.y : box.min.y,
                      (corner & 4) ? box.max.z : box.min.z);
    out.extend(glm::vec3(m * glm::vec4(p, 1.0f)));
  }
  return out;
}

}  // namespace

ObjectTransform fromWire(const protocol::Transform& t) {
  ObjectTransform out;
  if (t.matrix) {
    if (t.translation || t.rotation || t.scale) {
      throw ProblemError(invalidBody("/transform", "Give a transform as translation, rotation "
                                                   "and scale, or as a matrix, not both."));
    }
    glm::mat4 m(1.0f);
    for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = float((*t.matrix)[i]);
    out.matrix = m;
    return out;
  }
  if (t.translation) out.translation = fromWire(*t.translation);
  if (t.rotation) {
    const auto& r = *t.rotation;
    // glTF's order x, y, z, w; glm's constructor takes w first.
    const glm::quat q{float(r[3]), float(r[0]), float(r[1]), float(r[2])};
    const float length = glm::length(q);
    if (!(length > 1e-6f) || !std::isfinite(length)) {
      throw ProblemError(invalidBody("/transform/rotation",
                                     "The rotation quaternion must not be [0, 0, 0, 0]."));
    }
    // A unit quaternion (as answers give it back) is kept as sent.
    out.rotation = std::abs(length - 1.0f) <= 1e-6f ? q : q / length;
  }
  if (t.scale) out.scale = fromWire(*t.scale);
  return out;
}

protocol::Transform toWire(const ObjectTransform& t) {
  protocol::Transform out;
  if (t.matrix) {
    std::array<double, 16> m{};
    for (int i = 0; i < 16; ++i) m[i] = (*t.matrix)[i / 4][i % 4];
    out.matrix = m;
    return out;
  }
  out.translation = toWire(t.translation);
  out.rotation = std::array<double, 4>{t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w};
  out.scale = toWire(t.scale);
  return out;
}

void applyObjectPatch(const protocol::ObjectPatch& patch, SceneObject& o) {
  if (patch.name) o.name = *patch.name;
  if (patch.asset) o.asset = *patch.asset;
  if (patch.transform) o.transform = fromWire(*patch.transform);
  if (patch.visible) o.visible = *patch.visible;
  // The schema bounds ids to uint32.
  if (patch.parent) o.parent = uint32_t(patch.parent->value.value_or(0));
  if (patch.material) {
    o.material = patch.material->value ? std::optional<uint32_t>(uint32_t(*patch.material->value))
                                       : std::nullopt;
  }
  // A class name gets its id when the graph takes the object (SceneGraph::assignClasses).
  if (patch.semantic) {
    o.semanticClass = patch.semantic->name.value_or("");
    if (!patch.semantic->name) o.semantic = uint32_t(patch.semantic->id);
  }
  if (patch.subtree) o.subtree = *patch.subtree;
  // A node by index or null here; by name (nodeName) the route resolves it against the asset
  // (api_objects.cpp, which sees the session's assets).
  if (patch.node) o.node = patch.node->value ? int32_t(*patch.node->value) : -1;
  // A clip likewise: by index (the schema bounds it to 1023) or null here, by clipName there.
  if (patch.animation) {
    if (patch.animation->loop) o.loop = *patch.animation->loop;
    if (const auto& clip = patch.animation->clip) o.clip = clip->value ? int32_t(*clip->value) : -1;
  }
}

protocol::Object toWire(const SessionScene& scene, const SceneObject& o) {
  const SceneGraph& graph = scene.graph();
  protocol::Object out;
  out.id = o.id;
  out.name = o.name;
  out.asset = o.asset;
  out.transform = toWire(o.transform);
  out.visible = o.visible;
  if (o.parent != 0) out.parent.value = o.parent;
  if (o.material) out.material.value = *o.material;
  out.semantic = o.semanticClass.empty() ? protocol::Semantic{o.semantic, std::nullopt}
                                         : protocol::Semantic{0, o.semanticClass};
  const SceneGraph::Placement* placement = graph.placement(o.id);
  out.instances = placement != nullptr ? placement->count : 0;
  if (out.instances > 0) {
    const Asset& asset = graph.asset(o.asset);
    if (o.node >= 0) {
      // Part of the asset: the bounds of what it draws.
      if (const scene::Bounds b = graph.drawnBounds(o.id); !b.empty()) out.bounds = toWire(b);
    } else if (!asset.bounds.empty()) {
      out.bounds = toWire(movedBox(asset.bounds, graph.worldOf(o.id)));
    }
  }
  if (const Asset* asset = graph.findAsset(o.asset);
      asset != nullptr && o.node >= 0 && size_t(o.node) < asset->scene->nodes.size()) {
    out.node = uint64_t(o.node);
    out.nodeName = asset->scene->nodes[size_t(o.node)].name;
    out.subtree = o.subtree;
  }
  if (const Asset* asset = graph.findAsset(o.asset);
      asset != nullptr && !asset->scene->animations.empty()) {
    const auto& clips = asset->scene->animations;
    protocol::ObjectAnimation& animation = out.animation.emplace();
    animation.loop = o.loop;
    animation.clips = clips.size();
    animation.clip = protocol::Nullable<uint64_t>{};
    if (o.clip >= 0 && size_t(o.clip) < clips.size()) {
      animation.clip->value = uint64_t(o.clip);
      animation.clipName = clips[size_t(o.clip)].name;
      animation.duration = clips[size_t(o.clip)].duration;
    }
  }
  return out;
}

protocol::Asset toWire(const SceneGraph& graph, const Asset& a) {
  protocol::Asset out;
  out.id = a.id;
  out.source = a.source;
  out.bytes = a.bytes;
  out.meshes = a.scene->meshes.size();
  out.instances = a.scene->instances.size();
  out.materials = {a.firstMaterial, a.scene->materials.size()};
  out.images = a.scene->images.size();
  if (!a.bounds.empty()) out.bounds = toWire(a.bounds);
  out.objects = graph.usersOf(a);
  if (!a.scene->ignoredExtensions.empty()) out.ignoredExtensions = a.scene->ignoredExtensions;
  return out;
}

}  // namespace myriad::service
