// Between a session's state (scene units, glm) and the protocol's wire types (protocol/types.h).
// Callers hold the session's mutex while reading it.
#pragma once

#include <cstdint>
#include <string_view>

#include "protocol/types.h"
#include "render/frame.h"
#include "scene/scene.h"
#include "service/session.h"

namespace myriad::service {

protocol::Vec3 toWire(const glm::vec3& v);
glm::vec3 fromWire(const protocol::Vec3& v);

protocol::Camera toWire(const scene::Camera& camera);
scene::Camera fromWire(const protocol::Camera& camera);

protocol::Settings toWire(const render::SceneSettings& settings);
// Throws ProblemError 400 (/technique) for an unknown technique (the schema already limits it).
render::Technique techniqueFromWire(std::string_view name);
// The session's settings as GET .../settings answers them (the environment's source included).
protocol::Settings toWire(const SessionScene& scene);
// Throws ProblemError 400 (/antialias) for a name that is no anti-aliasing mode.
render::Antialias antialiasFromWire(std::string_view name);
render::LocalShadows localShadowsFromWire(std::string_view name);
// Throws ProblemError 400 (/environment/mode) for a name that is no environment mode.
render::EnvironmentMode environmentModeFromWire(std::string_view name);

// `images`: the model's (ModelSummary::images), which the material's textures index.
protocol::Material toWire(uint32_t id, const scene::Material& material,
                          const std::vector<ModelSummary::Image>& images);
// Throws ProblemError 400 (/alphaMode) for a name not in protocol::kAlphaModes.
scene::AlphaMode alphaModeFromWire(std::string_view name);
protocol::Light toWire(uint64_t id, const scene::PointLight& light);
// Check the light's members together (protocol::checkLight) and convert it; a broken light throws
// ProblemError 400 naming `pointer` + the member ("/lights/3/innerConeAngle").
scene::PointLight fromWire(const protocol::LightNew& light, std::string_view pointer);
scene::PointLight fromWire(const protocol::Light& light, std::string_view pointer,
                           bool blameOuter = false);
protocol::LightNew toWireNew(const scene::PointLight& light);

protocol::Bounds toWire(const scene::Bounds& bounds);
scene::Bounds fromWire(const protocol::Bounds& bounds);

// SessionState of `session` (whose mutex the caller holds).
protocol::SessionState stateOf(const Session& session, int64_t expiresInSeconds);

// Objects and assets (scene_graph.h) on the wire. fromWire(Transform) throws ProblemError 400
// for a transform with both TRS and a matrix (pointer /transform) or a zero rotation quaternion
// (/transform/rotation); applyObjectPatch sets the members a patch (or a new object) names.
ObjectTransform fromWire(const protocol::Transform& transform);
protocol::Transform toWire(const ObjectTransform& transform);
void applyObjectPatch(const protocol::ObjectPatch& patch, SceneObject& object);
protocol::Object toWire(const SessionScene& scene, const SceneObject& object);
protocol::Asset toWire(const SceneGraph& graph, const Asset& asset);

}  // namespace myriad::service
