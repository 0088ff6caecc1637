#include "protocol/types.h"

#include <nlohmann/json.hpp>

namespace myriad::protocol {
namespace {

using nlohmann::json;

// Readers and writers for one member; `get` is only called on validated JSON (see types.h).
template <class T>
void get(const json& j, const char* key, T& out) {
  j.at(key).get_to(out);
}

template <class T>
void get(const json& j, const char* key, std::optional<T>& out) {
  auto it = j.find(key);
  if (it == j.end()) {
    out.reset();
  } else {
    out = it->template get<T>();
  }
}

template <class T>
void put(json& j, const char* key, const T& value) {
  j[key] = value;
}

template <class T>
void put(json& j, const char* key, const std::optional<T>& value) {
  if (value) j[key] = *value;
}

// A member that is null when absent (stats' frame and culling) rather than left out.
template <class T>
json orNull(const std::optional<T>& value) {
  return value ? json(*value) : json(nullptr);
}

template <class T>
void patch(T& target, const std::optional<T>& value) {
  if (value) target = *value;
}

}  // namespace

Camera applied(Camera camera, const CameraPatch& p) {
  patch(camera.eye, p.eye);
  patch(camera.target, p.target);
  patch(camera.up, p.up);
  patch(camera.fovY, p.fovY);
  patch(camera.near, p.near);
  patch(camera.far, p.far);
  return camera;
}

Settings applied(Settings settings, const SettingsPatch& p) {
  if (p.sun) {
    patch(settings.sun.direction, p.sun->direction);
    patch(settings.sun.color, p.sun->color);
    patch(settings.sun.intensity, p.sun->intensity);
  }
  patch(settings.ambient, p.ambient);
  patch(settings.exposure, p.exposure);
  patch(settings.markers, p.markers);
  patch(settings.technique, p.technique);
  patch(settings.animate, p.animate);
  patch(settings.background, p.background);
  return settings;
}

Material applied(Material material, const MaterialPatch& p) {
  patch(material.baseColor, p.baseColor);
  patch(material.metallic, p.metallic);
  patch(material.roughness, p.roughness);
  return material;
}

Light withId(const LightNew& l, uint64_t id) {
  return Light{id, l.position, l.radius, l.color, l.intensity, l.falloff};
}

Light applied(Light light, const LightPatch& p) {
  patch(light.position, p.position);
  patch(light.radius, p.radius);
  patch(light.color, p.color);
  patch(light.intensity, p.intensity);
  patch(light.falloff, p.falloff);
  return light;
}

// Each type lists its members once per direction; the JSON names are the contract's.

void to_json(json& j, const Bounds& v) { j = {{"min", v.min}, {"max", v.max}}; }
void from_json(const json& j, Bounds& v) {
  get(j, "min", v.min);
  get(j, "max", v.max);
}

void to_json(json& j, const Camera& v) {
  j = {{"eye", v.eye}, {"target", v.target}, {"up", v.up},
       {"fovY", v.fovY}, {"near", v.near}, {"far", v.far}};
}
void from_json(const json& j, Camera& v) {
  get(j, "eye", v.eye);
  get(j, "target", v.target);
  get(j, "up", v.up);
  get(j, "fovY", v.fovY);
  get(j, "near", v.near);
  get(j, "far", v.far);
}

void to_json(json& j, const CameraPatch& v) {
  j = json::object();
  put(j, "eye", v.eye);
  put(j, "target", v.target);
  put(j, "up", v.up);
  put(j, "fovY", v.fovY);
  put(j, "near", v.near);
  put(j, "far", v.far);
}
void from_json(const json& j, CameraPatch& v) {
  get(j, "eye", v.eye);
  get(j, "target", v.target);
  get(j, "up", v.up);
  get(j, "fovY", v.fovY);
  get(j, "near", v.near);
  get(j, "far", v.far);
}

void to_json(json& j, const Sun& v) {
  j = {{"direction", v.direction}, {"color", v.color}, {"intensity", v.intensity}};
}
void from_json(const json& j, Sun& v) {
  get(j, "direction", v.direction);
  get(j, "color", v.color);
  get(j, "intensity", v.intensity);
}

void to_json(json& j, const SunPatch& v) {
  j = json::object();
  put(j, "direction", v.direction);
  put(j, "color", v.color);
  put(j, "intensity", v.intensity);
}
void from_json(const json& j, SunPatch& v) {
  get(j, "direction", v.direction);
  get(j, "color", v.color);
  get(j, "intensity", v.intensity);
}

void to_json(json& j, const Settings& v) {
  j = {{"sun", v.sun},         {"ambient", v.ambient},     {"exposure", v.exposure},
       {"markers", v.markers}, {"technique", v.technique}, {"animate", v.animate},
       {"background", v.background}};
}
void from_json(const json& j, Settings& v) {
  get(j, "sun", v.sun);
  get(j, "ambient", v.ambient);
  get(j, "exposure", v.exposure);
  get(j, "markers", v.markers);
  get(j, "technique", v.technique);
  get(j, "animate", v.animate);
  get(j, "background", v.background);
}

void to_json(json& j, const SettingsPatch& v) {
  j = json::object();
  put(j, "sun", v.sun);
  put(j, "ambient", v.ambient);
  put(j, "exposure", v.exposure);
  put(j, "markers", v.markers);
  put(j, "technique", v.technique);
  put(j, "animate", v.animate);
  put(j, "background", v.background);
}
void from_json(const json& j, SettingsPatch& v) {
  get(j, "sun", v.sun);
  get(j, "ambient", v.ambient);
  get(j, "exposure", v.exposure);
  get(j, "markers", v.markers);
  get(j, "technique", v.technique);
  get(j, "animate", v.animate);
  get(j, "background", v.background);
}

void to_json(json& j, const Material& v) {
  j = {{"id", v.id}, {"name", v.name}, {"baseColor", v.baseColor},
       {"metallic", v.metallic}, {"roughness", v.roughness}};
}
void from_json(const json& j, Material& v) {
  get(j, "id", v.id);
  get(j, "name", v.name);
  get(j, "baseColor", v.baseColor);
  get(j, "metallic", v.metallic);
  get(j, "roughness", v.roughness);
}

void to_json(json& j, const MaterialPatch& v) {
  j = json::object();
  put(j, "baseColor", v.baseColor);
  put(j, "metallic", v.metallic);
  put(j, "roughness", v.roughness);
}
void from_json(const json& j, MaterialPatch& v) {
  get(j, "baseColor", v.baseColor);
  get(j, "metallic", v.metallic);
  get(j, "roughness", v.roughness);
}

void to_json(json& j, const MaterialsList& v) { j = {{"materials", v.materials}}; }
void from_json(const json& j, MaterialsList& v) { get(j, "materials", v.materials); }

void to_json(json& j, const LightNew& v) {
  j = {{"position", v.position}, {"radius", v.radius}, {"color", v.color},
       {"intensity", v.intensity}, {"falloff", v.falloff}};
}
void from_json(const json& j, LightNew& v) {
  get(j, "position", v.position);
  get(j, "radius", v.radius);
  get(j, "color", v.color);
  get(j, "intensity", v.intensity);
  get(j, "falloff", v.falloff);
}

void to_json(json& j, const Light& v) {
  j = {{"id", v.id}, {"position", v.position}, {"radius", v.radius},
       {"color", v.color}, {"intensity", v.intensity}, {"falloff", v.falloff}};
}
void from_json(const json& j, Light& v) {
  get(j, "id", v.id);
  get(j, "position", v.position);
  get(j, "radius", v.radius);
  get(j, "color", v.color);
  get(j, "intensity", v.intensity);
  get(j, "falloff", v.falloff);
}

void to_json(json& j, const LightPatch& v) {
  j = json::object();
  put(j, "position", v.position);
  put(j, "radius", v.radius);
  put(j, "color", v.color);
  put(j, "intensity", v.intensity);
  put(j, "falloff", v.falloff);
}
void from_json(const json& j, LightPatch& v) {
  get(j, "position", v.position);
  get(j, "radius", v.radius);
  get(j, "color", v.color);
  get(j, "intensity", v.intensity);
  get(j, "falloff", v.falloff);
}

void to_json(json& j, const LightsAdd& v) { j = {{"lights", v.lights}}; }
void from_json(const json& j, LightsAdd& v) { get(j, "lights", v.lights); }

void to_json(json& j, const LightsAdded& v) { j = {{"ids", v.ids}, {"total", v.total}}; }
void from_json(const json& j, LightsAdded& v) {
  get(j, "ids", v.ids);
  get(j, "total", v.total);
}

void to_json(json& j, const Range& v) { j = json::array({v.min, v.max}); }
void from_json(const json& j, Range& v) {
  j.at(0).get_to(v.min);
  j.at(1).get_to(v.max);
}

void to_json(json& j, const LightsGenerate& v) {
  j = {{"count", v.count}, {"seed", v.seed}};
  put(j, "replace", v.replace);
  put(j, "bounds", v.bounds);
  put(j, "radius", v.radius);
  put(j, "intensity", v.intensity);
  put(j, "falloff", v.falloff);
}
void from_json(const json& j, LightsGenerate& v) {
  get(j, "count", v.count);
  get(j, "seed", v.seed);
  get(j, "replace", v.replace);
  get(j, "bounds", v.bounds);
  get(j, "radius", v.radius);
  get(j, "intensity", v.intensity);
  get(j, "falloff", v.falloff);
}

void to_json(json& j, const LightsGenerated& v) { j = {{"total", v.total}}; }
void from_json(const json& j, LightsGenerated& v) { get(j, "total", v.total); }

void to_json(json& j, const LightsPage& v) {
  j = {{"total", v.total}, {"offset", v.offset}, {"lights", v.lights}};
}
void from_json(const json& j, LightsPage& v) {
  get(j, "total", v.total);
  get(j, "offset", v.offset);
  get(j, "lights", v.lights);
}

void to_json(json& j, const ModelSource& v) { j = {{"source", v.source}}; }
void from_json(const json& j, ModelSource& v) { get(j, "source", v.source); }

void to_json(json& j, const SessionCreate& v) {
  j = json::object();
  put(j, "model", v.model);
}
void from_json(const json& j, SessionCreate& v) { get(j, "model", v.model); }

void to_json(json& j, const ModelSummary& v) {
  j = {{"source", v.source},       {"meshes", v.meshes}, {"instances", v.instances},
       {"materials", v.materials}, {"bounds", v.bounds}};
}
void from_json(const json& j, ModelSummary& v) {
  get(j, "source", v.source);
  get(j, "meshes", v.meshes);
  get(j, "instances", v.instances);
  get(j, "materials", v.materials);
  get(j, "bounds", v.bounds);
}

void to_json(json& j, const SessionState& v) {
  j = {{"id", v.id},
       {"model", v.model},
       {"camera", v.camera},
       {"settings", v.settings},
       {"lights", {{"count", v.lightCount}}},
       {"expiresInSeconds", v.expiresInSeconds}};
}
void from_json(const json& j, SessionState& v) {
  get(j, "id", v.id);
  get(j, "model", v.model);
  get(j, "camera", v.camera);
  get(j, "settings", v.settings);
  get(j.at("lights"), "count", v.lightCount);
  get(j, "expiresInSeconds", v.expiresInSeconds);
}

void to_json(json& j, const SessionCreated& v) {
  j = {{"id", v.id},
       {"token", v.token},
       {"expiresInSeconds", v.expiresInSeconds},
       {"session", v.session}};
}
void from_json(const json& j, SessionCreated& v) {
  get(j, "id", v.id);
  get(j, "token", v.token);
  get(j, "expiresInSeconds", v.expiresInSeconds);
  get(j, "session", v.session);
}

void to_json(json& j, const PassTiming& v) { j = {{"name", v.name}, {"ms", v.ms}}; }
void from_json(const json& j, PassTiming& v) {
  get(j, "name", v.name);
  get(j, "ms", v.ms);
}

void to_json(json& j, const FrameStats& v) {
  j = {{"passes", v.passes},         {"totalGpuMs", v.totalGpuMs}, {"readbackMs", v.readbackMs},
       {"encodeMs", v.encodeMs},     {"width", v.width},           {"height", v.height},
       {"technique", v.technique},   {"target", v.target}};
}
void from_json(const json& j, FrameStats& v) {
  get(j, "passes", v.passes);
  get(j, "totalGpuMs", v.totalGpuMs);
  get(j, "readbackMs", v.readbackMs);
  get(j, "encodeMs", v.encodeMs);
  get(j, "width", v.width);
  get(j, "height", v.height);
  get(j, "technique", v.technique);
  get(j, "target", v.target);
}

void to_json(json& j, const CullingStats& v) {
  j = {{"tilesOverflowed", v.tilesOverflowed},
       {"tileLightsDropped", v.tileLightsDropped},
       {"clusterLightsDropped", v.clusterLightsDropped},
       {"listEntries", v.listEntries},
       {"activeClusters", v.activeClusters},
       {"mostLightsInList", v.mostLightsInList}};
}
void from_json(const json& j, CullingStats& v) {
  get(j, "tilesOverflowed", v.tilesOverflowed);
  get(j, "tileLightsDropped", v.tileLightsDropped);
  get(j, "clusterLightsDropped", v.clusterLightsDropped);
  get(j, "listEntries", v.listEntries);
  get(j, "activeClusters", v.activeClusters);
  get(j, "mostLightsInList", v.mostLightsInList);
}

void to_json(json& j, const GpuMemory& v) {
  j = {{"lightBytes", v.lightBytes}, {"listBytes", v.listBytes}, {"sceneBytes", v.sceneBytes}};
}
void from_json(const json& j, GpuMemory& v) {
  get(j, "lightBytes", v.lightBytes);
  get(j, "listBytes", v.listBytes);
  get(j, "sceneBytes", v.sceneBytes);
}

void to_json(json& j, const Stats& v) {
  j = {{"frame", orNull(v.frame)},
       {"lights", {{"count", v.lightCount}, {"animated", v.lightsAnimated}}},
       {"culling", orNull(v.culling)},
       {"gpuMemory", v.gpuMemory},
       {"frames", v.frames}};
}
void from_json(const json& j, Stats& v) {
  const json& frame = j.at("frame");
  v.frame = frame.is_null() ? std::nullopt : std::optional(frame.get<FrameStats>());
  get(j.at("lights"), "count", v.lightCount);
  get(j.at("lights"), "animated", v.lightsAnimated);
  const json& culling = j.at("culling");
  v.culling = culling.is_null() ? std::nullopt : std::optional(culling.get<CullingStats>());
  get(j, "gpuMemory", v.gpuMemory);
  get(j, "frames", v.frames);
}

void to_json(json& j, const Limits& v) {
  j = {{"maxResolution", v.maxResolution},
       {"maxQueuedFrames", v.maxQueuedFrames},
       {"maxSessions", v.maxSessions},
       {"maxLightsPerSession", v.maxLightsPerSession},
       {"maxUploadBytes", v.maxUploadBytes},
       {"maxBodyBytes", v.maxBodyBytes},
       {"maxStreams", v.maxStreams},
       {"maxRequestsInFlight", v.maxRequestsInFlight},
       {"sessionIdleSeconds", v.sessionIdleSeconds}};
}
void from_json(const json& j, Limits& v) {
  get(j, "maxResolution", v.maxResolution);
  get(j, "maxQueuedFrames", v.maxQueuedFrames);
  get(j, "maxSessions", v.maxSessions);
  get(j, "maxLightsPerSession", v.maxLightsPerSession);
  get(j, "maxUploadBytes", v.maxUploadBytes);
  get(j, "maxBodyBytes", v.maxBodyBytes);
  get(j, "maxStreams", v.maxStreams);
  get(j, "maxRequestsInFlight", v.maxRequestsInFlight);
  get(j, "sessionIdleSeconds", v.sessionIdleSeconds);
}

void to_json(json& j, const DeviceSummary& v) {
  j = {{"name", v.name},
       {"type", v.type},
       {"driverName", v.driverName},
       {"driverInfo", v.driverInfo},
       {"apiVersion", v.apiVersion},
       {"vendorId", v.vendorId},
       {"deviceId", v.deviceId},
       {"index", v.index},
       {"isCpu", v.isCpu},
       {"maxImageDimension2D", v.maxImageDimension2D},
       {"maxStorageBufferRange", v.maxStorageBufferRange},
       {"maxComputeSharedMemorySize", v.maxComputeSharedMemorySize},
       {"subgroupSize", v.subgroupSize},
       {"timestampPeriodNs", v.timestampPeriodNs},
       {"timestampsSupported", v.timestampsSupported}};
}
void from_json(const json& j, DeviceSummary& v) {
  get(j, "name", v.name);
  get(j, "type", v.type);
  get(j, "driverName", v.driverName);
  get(j, "driverInfo", v.driverInfo);
  get(j, "apiVersion", v.apiVersion);
  get(j, "vendorId", v.vendorId);
  get(j, "deviceId", v.deviceId);
  get(j, "index", v.index);
  get(j, "isCpu", v.isCpu);
  get(j, "maxImageDimension2D", v.maxImageDimension2D);
  get(j, "maxStorageBufferRange", v.maxStorageBufferRange);
  get(j, "maxComputeSharedMemorySize", v.maxComputeSharedMemorySize);
  get(j, "subgroupSize", v.subgroupSize);
  get(j, "timestampPeriodNs", v.timestampPeriodNs);
  get(j, "timestampsSupported", v.timestampsSupported);
}

void to_json(json& j, const SceneCounts& v) {
  j = {{"lights", v.lights}, {"instances", v.instances},
       {"materials", v.materials}, {"meshes", v.meshes}};
}
void from_json(const json& j, SceneCounts& v) {
  get(j, "lights", v.lights);
  get(j, "instances", v.instances);
  get(j, "materials", v.materials);
  get(j, "meshes", v.meshes);
}

void to_json(json& j, const Info& v) {
  j = {{"server", {{"name", v.serverName}, {"version", v.serverVersion}}},
       {"device", v.device},
       {"limits", v.limits},
       {"sessions", {{"open", v.openSessions}}},
       {"gpuMemoryBytes", v.gpuMemoryBytes},
       {"validation", {{"enabled", v.validationEnabled}, {"messages", v.validationMessages}}},
       {"scene", v.scene},
       {"targets", v.targets},
       {"techniques", v.techniques},
       {"defaultTechnique", v.defaultTechnique},
       {"formats", v.formats},
       {"apiKeyRequired", v.apiKeyRequired}};
}
void from_json(const json& j, Info& v) {
  get(j.at("server"), "name", v.serverName);
  get(j.at("server"), "version", v.serverVersion);
  get(j, "device", v.device);
  get(j, "limits", v.limits);
  get(j.at("sessions"), "open", v.openSessions);
  get(j, "gpuMemoryBytes", v.gpuMemoryBytes);
  get(j.at("validation"), "enabled", v.validationEnabled);
  get(j.at("validation"), "messages", v.validationMessages);
  get(j, "scene", v.scene);
  get(j, "targets", v.targets);
  get(j, "techniques", v.techniques);
  get(j, "defaultTechnique", v.defaultTechnique);
  get(j, "formats", v.formats);
  get(j, "apiKeyRequired", v.apiKeyRequired);
}

void to_json(json& j, const LibraryModel& v) { j = {{"name", v.name}, {"bytes", v.bytes}}; }
void from_json(const json& j, LibraryModel& v) {
  get(j, "name", v.name);
  get(j, "bytes", v.bytes);
}

void to_json(json& j, const ModelsList& v) { j = {{"models", v.models}}; }
void from_json(const json& j, ModelsList& v) { get(j, "models", v.models); }

void to_json(json& j, const Health& v) { j = {{"status", v.status}}; }
void from_json(const json& j, Health& v) { get(j, "status", v.status); }

void to_json(json& j, const Problem& v) {
  j = {{"type", v.type}, {"title", v.title}, {"status", v.status}, {"detail", v.detail}};
  put(j, "parameter", v.parameter);
  put(j, "pointer", v.pointer);
  put(j, "limit", v.limit);
}
void from_json(const json& j, Problem& v) {
  get(j, "type", v.type);
  get(j, "title", v.title);
  get(j, "status", v.status);
  get(j, "detail", v.detail);
  get(j, "parameter", v.parameter);
  get(j, "pointer", v.pointer);
  get(j, "limit", v.limit);
}

}  // namespace myriad::protocol
