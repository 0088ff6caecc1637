#include "service/session_json.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include "protocol/validate.h"
#include "service/problem.h"

namespace myriad::service {
namespace {

using nlohmann::json;


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

}  // namespace

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
  if (!mode) throw ProblemError(invalidBody("/antialias", "\"antialias\" must be none or fxaa."));
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
  state.camera = toWire(scene.camera());
  state.settings = toWire(scene);
  state.lightCount = scene.lightCount();
  state.expiresInSeconds = uint64_t(std::max<int64_t>(0, expiresInSeconds));
  return state;
}

// The members of an object-new or object-patch body onto `o` (a patch: only those present).
void applyObjectMembers(const nlohmann::json& j, SceneObject& o) {
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

nlohmann::json toWire(const SessionScene& scene, const SceneObject& o) {
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

nlohmann::json toWire(const SceneGraph& graph, const Asset& a) {
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

}  // namespace myriad::service
