#include "protocol/types.h"

#include <nlohmann/json.hpp>

#include <type_traits>

namespace myriad::protocol {
namespace {

using nlohmann::json;

// Readers and writers for one member (protocol/members.h); `get` is only called on validated
// JSON (see types.h). An optional member is left out when absent, in both directions.
using members_json::get;
using members_json::put;

// Settings' environment may be absent from a body (a snapshot saved before environments
// existed): it then reads as the default, mode none, which is how that snapshot looked.
void get(const json& j, const char* key, Environment& out) {
  auto it = j.find(key);
  out = it == j.end() ? Environment{} : it->get<Environment>();
}

// Settings' shadows likewise (a snapshot from before shadows): off.
void get(const json& j, const char* key, Shadows& out) {
  auto it = j.find(key);
  out = it == j.end() ? Shadows{} : it->get<Shadows>();
}

// Settings' fog likewise (a snapshot from before fog): off.
void get(const json& j, const char* key, Fog& out) {
  auto it = j.find(key);
  out = it == j.end() ? Fog{} : it->get<Fog>();
}

// A member that is null when absent (stats' frame and culling) rather than left out.
template <class T>
json orNull(const std::optional<T>& value) {
  return value ? json(*value) : json(nullptr);
}

// Each type names its members once, in a members() overload: f(JSON name, member pointer) for
// each. A patch type names them in patchMembers(): f(JSON name, member of the whole type, the
// patch's optional member), which gives its members() and applied() both.
template <class F>
void members(Tag<Bounds>, F f) {
  f("min", &Bounds::min);
  f("max", &Bounds::max);
}

template <class F>
void patchMembers(Tag<CameraPatch>, F f) {
  f("eye", &Camera::eye, &CameraPatch::eye);
  f("target", &Camera::target, &CameraPatch::target);
  f("up", &Camera::up, &CameraPatch::up);
  f("fovY", &Camera::fovY, &CameraPatch::fovY);
  f("near", &Camera::near, &CameraPatch::near);
  f("far", &Camera::far, &CameraPatch::far);
}

template <class F>
void patchMembers(Tag<SunPatch>, F f) {
  f("direction", &Sun::direction, &SunPatch::direction);
  f("color", &Sun::color, &SunPatch::color);
  f("intensity", &Sun::intensity, &SunPatch::intensity);
}

template <class F>
void patchMembers(Tag<EnvironmentPatch>, F f) {
  f("mode", &Environment::mode, &EnvironmentPatch::mode);
  f("intensity", &Environment::intensity, &EnvironmentPatch::intensity);
  f("rotation", &Environment::rotation, &EnvironmentPatch::rotation);
  f("background", &Environment::background, &EnvironmentPatch::background);
}

template <class F>
void patchMembers(Tag<ShadowsPatch>, F f) {
  f("sun", &Shadows::sun, &ShadowsPatch::sun);
  f("mapSize", &Shadows::mapSize, &ShadowsPatch::mapSize);
  f("maxShadowedLights", &Shadows::maxShadowedLights, &ShadowsPatch::maxShadowedLights);
  f("local", &Shadows::local, &ShadowsPatch::local);
  f("cascades", &Shadows::cascades, &ShadowsPatch::cascades);
}

template <class F>
void patchMembers(Tag<FogPatch>, F f) {
  f("density", &Fog::density, &FogPatch::density);
  f("color", &Fog::color, &FogPatch::color);
}

template <class F>
void patchMembers(Tag<SettingsPatch>, F f) {
  f("sun", &Settings::sun, &SettingsPatch::sun);
  f("suns", &Settings::suns, &SettingsPatch::suns);
  f("ambient", &Settings::ambient, &SettingsPatch::ambient);
  f("exposure", &Settings::exposure, &SettingsPatch::exposure);
  f("markers", &Settings::markers, &SettingsPatch::markers);
  f("antialias", &Settings::antialias, &SettingsPatch::antialias);
  f("technique", &Settings::technique, &SettingsPatch::technique);
  f("animate", &Settings::animate, &SettingsPatch::animate);
  f("background", &Settings::background, &SettingsPatch::background);
  f("environment", &Settings::environment, &SettingsPatch::environment);
  f("shadows", &Settings::shadows, &SettingsPatch::shadows);
  f("fog", &Settings::fog, &SettingsPatch::fog);
}

template <class F>
void patchMembers(Tag<MaterialPatch>, F f) {
  f("baseColor", &Material::baseColor, &MaterialPatch::baseColor);
  f("metallic", &Material::metallic, &MaterialPatch::metallic);
  f("roughness", &Material::roughness, &MaterialPatch::roughness);
  f("alpha", &Material::alpha, &MaterialPatch::alpha);
  f("emissive", &Material::emissive, &MaterialPatch::emissive);
  f("emissiveStrength", &Material::emissiveStrength, &MaterialPatch::emissiveStrength);
  f("normalScale", &Material::normalScale, &MaterialPatch::normalScale);
  f("occlusionStrength", &Material::occlusionStrength, &MaterialPatch::occlusionStrength);
  f("alphaMode", &Material::alphaMode, &MaterialPatch::alphaMode);
  f("alphaCutoff", &Material::alphaCutoff, &MaterialPatch::alphaCutoff);
  f("doubleSided", &Material::doubleSided, &MaterialPatch::doubleSided);
  f("clearcoat", &Material::clearcoat, &MaterialPatch::clearcoat);
  f("clearcoatRoughness", &Material::clearcoatRoughness, &MaterialPatch::clearcoatRoughness);
  f("sheenColor", &Material::sheenColor, &MaterialPatch::sheenColor);
  f("sheenRoughness", &Material::sheenRoughness, &MaterialPatch::sheenRoughness);
  f("ior", &Material::ior, &MaterialPatch::ior);
  f("specular", &Material::specular, &MaterialPatch::specular);
}

template <class F>
void patchMembers(Tag<LightPatch>, F f) {
  f("position", &Light::position, &LightPatch::position);
  f("radius", &Light::radius, &LightPatch::radius);
  f("color", &Light::color, &LightPatch::color);
  f("intensity", &Light::intensity, &LightPatch::intensity);
  f("falloff", &Light::falloff, &LightPatch::falloff);
  f("type", &Light::type, &LightPatch::type);
  f("attenuation", &Light::attenuation, &LightPatch::attenuation);
  f("direction", &Light::direction, &LightPatch::direction);
  f("innerConeAngle", &Light::innerConeAngle, &LightPatch::innerConeAngle);
  f("outerConeAngle", &Light::outerConeAngle, &LightPatch::outerConeAngle);
  f("castsShadows", &Light::castsShadows, &LightPatch::castsShadows);
}

// The two halves of a patch list: the whole type's members, and the patch's.
template <class P, class F>
void wholeMembers(F& f) {
  patchMembers(Tag<P>{}, [&](const char* name, auto whole, auto) { f(name, whole); });
}

template <class P, class F>
void patchedMembers(F& f) {
  patchMembers(Tag<P>{}, [&](const char* name, auto, auto patched) { f(name, patched); });
}

// Camera, Sun and Settings are exactly what their patches can change.
template <class F> void members(Tag<Camera>, F f) { wholeMembers<CameraPatch>(f); }
template <class F> void members(Tag<CameraPatch>, F f) { patchedMembers<CameraPatch>(f); }
template <class F> void members(Tag<Sun>, F f) { wholeMembers<SunPatch>(f); }
template <class F> void members(Tag<SunPatch>, F f) { patchedMembers<SunPatch>(f); }
template <class F> void members(Tag<Environment>, F f) {
  wholeMembers<EnvironmentPatch>(f);
  f("source", &Environment::source);
}
template <class F> void members(Tag<EnvironmentPatch>, F f) { patchedMembers<EnvironmentPatch>(f); }
template <class F> void members(Tag<Shadows>, F f) { wholeMembers<ShadowsPatch>(f); }
template <class F> void members(Tag<ShadowsPatch>, F f) { patchedMembers<ShadowsPatch>(f); }
template <class F> void members(Tag<Fog>, F f) { wholeMembers<FogPatch>(f); }
template <class F> void members(Tag<FogPatch>, F f) { patchedMembers<FogPatch>(f); }
template <class F> void members(Tag<Settings>, F f) { wholeMembers<SettingsPatch>(f); }
template <class F> void members(Tag<SettingsPatch>, F f) { patchedMembers<SettingsPatch>(f); }
template <class F> void members(Tag<MaterialPatch>, F f) { patchedMembers<MaterialPatch>(f); }
template <class F> void members(Tag<LightPatch>, F f) { patchedMembers<LightPatch>(f); }

// A material and a light also have what no patch changes: the id (and a material's name).
template <class F>
void members(Tag<Material>, F f) {
  f("id", &Material::id);
  f("name", &Material::name);
  wholeMembers<MaterialPatch>(f);
  f("textures", &Material::textures);
}

template <class F>
void members(Tag<MaterialTexture>, F f) {
  f("slot", &MaterialTexture::slot);
  f("image", &MaterialTexture::image);
  f("width", &MaterialTexture::width);
  f("height", &MaterialTexture::height);
  f("wrapS", &MaterialTexture::wrapS);
  f("wrapT", &MaterialTexture::wrapT);
  f("magFilter", &MaterialTexture::magFilter);
  f("minFilter", &MaterialTexture::minFilter);
  f("mipmaps", &MaterialTexture::mipmaps);
}

template <class F>
void members(Tag<Light>, F f) {
  f("id", &Light::id);
  wholeMembers<LightPatch>(f);
}

template <class F>
void members(Tag<LightNew>, F f) {
  f("position", &LightNew::position);
  f("radius", &LightNew::radius);
  f("color", &LightNew::color);
  f("intensity", &LightNew::intensity);
  f("falloff", &LightNew::falloff);
  f("type", &LightNew::type);
  f("attenuation", &LightNew::attenuation);
  f("direction", &LightNew::direction);
  f("innerConeAngle", &LightNew::innerConeAngle);
  f("outerConeAngle", &LightNew::outerConeAngle);
  f("castsShadows", &LightNew::castsShadows);
}

template <class F>
void members(Tag<MaterialsList>, F f) {
  f("materials", &MaterialsList::materials);
}

template <class F>
void members(Tag<LightsAdd>, F f) {
  f("lights", &LightsAdd::lights);
}

template <class F>
void members(Tag<LightsAdded>, F f) {
  f("ids", &LightsAdded::ids);
  f("total", &LightsAdded::total);
}

template <class F>
void members(Tag<LightsGenerate>, F f) {
  f("count", &LightsGenerate::count);
  f("seed", &LightsGenerate::seed);
  f("replace", &LightsGenerate::replace);
  f("bounds", &LightsGenerate::bounds);
  f("radius", &LightsGenerate::radius);
  f("intensity", &LightsGenerate::intensity);
  f("falloff", &LightsGenerate::falloff);
}

template <class F>
void members(Tag<LightsGenerated>, F f) {
  f("total", &LightsGenerated::total);
}

template <class F>
void members(Tag<LightsPage>, F f) {
  f("total", &LightsPage::total);
  f("offset", &LightsPage::offset);
  f("lights", &LightsPage::lights);
}

template <class F>
void members(Tag<ModelSource>, F f) {
  f("source", &ModelSource::source);
}

template <class F>
void members(Tag<LightsRecipe>, F f) {
  f("count", &LightsRecipe::count);
  f("seed", &LightsRecipe::seed);
}

template <class F>
void members(Tag<SnapshotLights>, F f) {
  f("generated", &SnapshotLights::generated);
  f("list", &SnapshotLights::list);
}

template <class F>
void members(Tag<Transform>, F f) {
  f("translation", &Transform::translation);
  f("rotation", &Transform::rotation);
  f("scale", &Transform::scale);
  f("matrix", &Transform::matrix);
}

template <class F>
void members(Tag<ObjectPatch>, F f) {
  f("name", &ObjectPatch::name);
  f("asset", &ObjectPatch::asset);
  f("transform", &ObjectPatch::transform);
  f("visible", &ObjectPatch::visible);
  f("parent", &ObjectPatch::parent);
  f("material", &ObjectPatch::material);
  f("semantic", &ObjectPatch::semantic);
  f("animation", &ObjectPatch::animation);
  f("node", &ObjectPatch::node);
  f("nodeName", &ObjectPatch::nodeName);
  f("subtree", &ObjectPatch::subtree);
  f("tree", &ObjectPatch::tree);
}

template <class F>
void members(Tag<ObjectAnimation>, F f) {
  f("clip", &ObjectAnimation::clip);
  f("clipName", &ObjectAnimation::clipName);
  f("loop", &ObjectAnimation::loop);
  f("duration", &ObjectAnimation::duration);
  f("clips", &ObjectAnimation::clips);
}

template <class F>
void members(Tag<Clock>, F f) {
  f("time", &Clock::time);
  f("playing", &Clock::playing);
  f("rate", &Clock::rate);
  f("duration", &Clock::duration);
}

template <class F>
void members(Tag<ClockPatch>, F f) {
  f("time", &ClockPatch::time);
  f("playing", &ClockPatch::playing);
  f("rate", &ClockPatch::rate);
}

template <class F>
void members(Tag<ObjectsAdd>, F f) {
  f("objects", &ObjectsAdd::objects);
}

template <class F>
void members(Tag<ObjectsAdded>, F f) {
  f("ids", &ObjectsAdded::ids);
  f("total", &ObjectsAdded::total);
}

template <class F>
void members(Tag<Object>, F f) {
  f("id", &Object::id);
  f("name", &Object::name);
  f("asset", &Object::asset);
  f("transform", &Object::transform);
  f("visible", &Object::visible);
  f("parent", &Object::parent);
  f("material", &Object::material);
  f("semantic", &Object::semantic);
  f("instances", &Object::instances);
  f("bounds", &Object::bounds);
  f("animation", &Object::animation);
  f("node", &Object::node);
  f("nodeName", &Object::nodeName);
  f("subtree", &Object::subtree);
}

template <class F>
void members(Tag<ObjectsPage>, F f) {
  f("total", &ObjectsPage::total);
  f("offset", &ObjectsPage::offset);
  f("nextObjectId", &ObjectsPage::nextObjectId);
  f("objects", &ObjectsPage::objects);
}

template <class F>
void members(Tag<AssetMaterials>, F f) {
  f("first", &AssetMaterials::first);
  f("count", &AssetMaterials::count);
}

template <class F>
void members(Tag<Asset>, F f) {
  f("id", &Asset::id);
  f("source", &Asset::source);
  f("bytes", &Asset::bytes);
  f("meshes", &Asset::meshes);
  f("instances", &Asset::instances);
  f("materials", &Asset::materials);
  f("images", &Asset::images);
  f("bounds", &Asset::bounds);
  f("objects", &Asset::objects);
  f("ignoredExtensions", &Asset::ignoredExtensions);
}

template <class F>
void members(Tag<AssetsList>, F f) {
  f("assets", &AssetsList::assets);
}

template <class F>
void members(Tag<FrameIntrinsics>, F f) {
  f("fx", &FrameIntrinsics::fx);
  f("fy", &FrameIntrinsics::fy);
  f("cx", &FrameIntrinsics::cx);
  f("cy", &FrameIntrinsics::cy);
  f("width", &FrameIntrinsics::width);
  f("height", &FrameIntrinsics::height);
  f("near", &FrameIntrinsics::near);
  f("far", &FrameIntrinsics::far);
}

template <class F>
void members(Tag<ObjectLabel>, F f) {
  f("id", &ObjectLabel::id);
  f("semantic", &ObjectLabel::semantic);
  f("pixels", &ObjectLabel::pixels);
  f("box", &ObjectLabel::box);
  f("bounds", &ObjectLabel::bounds);
  f("totalPixels", &ObjectLabel::totalPixels);
}

template <class F>
void members(Tag<Labels>, F f) {
  f("width", &Labels::width);
  f("height", &Labels::height);
  f("intrinsics", &Labels::intrinsics);
  f("worldFromCamera", &Labels::worldFromCamera);
  f("objects", &Labels::objects);
  f("classes", &Labels::classes);
}

template <class F>
void members(Tag<SemanticClass>, F f) {
  f("name", &SemanticClass::name);
  f("id", &SemanticClass::id);
}

template <class F>
void members(Tag<SnapshotAsset>, F f) {
  f("id", &SnapshotAsset::id);
  f("source", &SnapshotAsset::source);
}

template <class F>
void members(Tag<SnapshotScene>, F f) {
  f("assets", &SnapshotScene::assets);
  f("objects", &SnapshotScene::objects);
  f("nextObjectId", &SnapshotScene::nextObjectId);
  f("classes", &SnapshotScene::classes);
}

template <class F>
void members(Tag<Snapshot>, F f) {
  f("version", &Snapshot::version);
  f("model", &Snapshot::model);
  f("camera", &Snapshot::camera);
  f("settings", &Snapshot::settings);
  f("materials", &Snapshot::materials);
  f("lights", &Snapshot::lights);
  f("scene", &Snapshot::scene);
}

template <class F>
void members(Tag<SessionCreate>, F f) {
  f("model", &SessionCreate::model);
  f("snapshot", &SessionCreate::snapshot);
}

template <class F>
void members(Tag<ModelSummary>, F f) {
  f("source", &ModelSummary::source);
  f("meshes", &ModelSummary::meshes);
  f("instances", &ModelSummary::instances);
  f("materials", &ModelSummary::materials);
  f("bounds", &ModelSummary::bounds);
  f("cameras", &ModelSummary::cameras);
  f("lights", &ModelSummary::lights);
  f("ignoredExtensions", &ModelSummary::ignoredExtensions);
}

template <class F>
void members(Tag<ModelCamera>, F f) {
  f("index", &ModelCamera::index);
  f("name", &ModelCamera::name);
  f("type", &ModelCamera::type);
  f("yfov", &ModelCamera::yfov);
  f("aspectRatio", &ModelCamera::aspectRatio);
  f("znear", &ModelCamera::znear);
  f("zfar", &ModelCamera::zfar);
  f("position", &ModelCamera::position);
  f("direction", &ModelCamera::direction);
  f("up", &ModelCamera::up);
}

template <class F>
void members(Tag<ModelLights>, F f) {
  f("point", &ModelLights::point);
  f("spot", &ModelLights::spot);
  f("directional", &ModelLights::directional);
  f("directionalDropped", &ModelLights::directionalDropped);
}

template <class F>
void members(Tag<CameraSelect>, F f) {
  f("modelCamera", &CameraSelect::modelCamera);
}

template <class F>
void members(Tag<TokenCreate>, F f) {
  f("role", &TokenCreate::role);
  f("ttlSeconds", &TokenCreate::ttlSeconds);
}

template <class F>
void members(Tag<TokenCreated>, F f) {
  f("token", &TokenCreated::token);
  f("role", &TokenCreated::role);
  f("expiresInSeconds", &TokenCreated::expiresInSeconds);
  f("link", &TokenCreated::link);
}

template <class F>
void members(Tag<LightPick>, F f) {
  f("light", &LightPick::light);
  f("distance", &LightPick::distance);
  f("candidates", &LightPick::candidates);
}

template <class F>
void members(Tag<SessionCreated>, F f) {
  f("id", &SessionCreated::id);
  f("token", &SessionCreated::token);
  f("expiresInSeconds", &SessionCreated::expiresInSeconds);
  f("session", &SessionCreated::session);
}

template <class F>
void members(Tag<PassTiming>, F f) {
  f("name", &PassTiming::name);
  f("ms", &PassTiming::ms);
}

template <class F>
void members(Tag<FrameStats>, F f) {
  f("passes", &FrameStats::passes);
  f("totalGpuMs", &FrameStats::totalGpuMs);
  f("readbackMs", &FrameStats::readbackMs);
  f("encodeMs", &FrameStats::encodeMs);
  f("width", &FrameStats::width);
  f("height", &FrameStats::height);
  f("technique", &FrameStats::technique);
  f("target", &FrameStats::target);
}

template <class F>
void members(Tag<CullingStats>, F f) {
  f("tilesOverflowed", &CullingStats::tilesOverflowed);
  f("tileLightsDropped", &CullingStats::tileLightsDropped);
  f("clusterLightsDropped", &CullingStats::clusterLightsDropped);
  f("listEntries", &CullingStats::listEntries);
  f("activeClusters", &CullingStats::activeClusters);
  f("mostLightsInList", &CullingStats::mostLightsInList);
}

template <class F>
void members(Tag<LightShadowStats>, F f) {
  f("lights", &LightShadowStats::lights);
  f("requested", &LightShadowStats::requested);
  f("dropped", &LightShadowStats::dropped);
}

template <class F>
void members(Tag<PipelineStats>, F f) {
  f("frames", &PipelineStats::frames);
  f("queueMs", &PipelineStats::queueMs);
  f("recordMs", &PipelineStats::recordMs);
  f("gpuMs", &PipelineStats::gpuMs);
  f("gpuIdleMs", &PipelineStats::gpuIdleMs);
  f("fenceWaitMs", &PipelineStats::fenceWaitMs);
  f("copyMs", &PipelineStats::copyMs);
  f("answerMs", &PipelineStats::answerMs);
  f("waitMs", &PipelineStats::waitMs);
  f("encodeMs", &PipelineStats::encodeMs);
  f("parts", &PipelineStats::parts);
  f("sendMs", &PipelineStats::sendMs);
  f("intervalMs", &PipelineStats::intervalMs);
}

template <class F>
void members(Tag<GpuMemory>, F f) {
  f("lightBytes", &GpuMemory::lightBytes);
  f("listBytes", &GpuMemory::listBytes);
  f("sceneBytes", &GpuMemory::sceneBytes);
}

template <class F>
void members(Tag<Limits>, F f) {
  f("maxResolution", &Limits::maxResolution);
  f("maxQueuedFrames", &Limits::maxQueuedFrames);
  f("maxSessions", &Limits::maxSessions);
  f("maxLightsPerSession", &Limits::maxLightsPerSession);
  f("maxObjectsPerSession", &Limits::maxObjectsPerSession);
  f("maxUploadBytes", &Limits::maxUploadBytes);
  f("maxBodyBytes", &Limits::maxBodyBytes);
  f("maxStreams", &Limits::maxStreams);
  f("maxStreamsPerSession", &Limits::maxStreamsPerSession);
  f("maxMemoryBytes", &Limits::maxMemoryBytes);
  f("maxFrameSeconds", &Limits::maxFrameSeconds);
  f("maxEventStreamsPerSession", &Limits::maxEventStreamsPerSession);
  f("maxEventStreams", &Limits::maxEventStreams);
  f("maxFrameTargets", &Limits::maxFrameTargets);
  f("maxRequestsInFlight", &Limits::maxRequestsInFlight);
  f("sessionIdleSeconds", &Limits::sessionIdleSeconds);
}

template <class F>
void members(Tag<DeviceSummary>, F f) {
  f("name", &DeviceSummary::name);
  f("type", &DeviceSummary::type);
  f("driverName", &DeviceSummary::driverName);
  f("driverInfo", &DeviceSummary::driverInfo);
  f("apiVersion", &DeviceSummary::apiVersion);
  f("vendorId", &DeviceSummary::vendorId);
  f("deviceId", &DeviceSummary::deviceId);
  f("index", &DeviceSummary::index);
  f("isCpu", &DeviceSummary::isCpu);
  f("maxImageDimension2D", &DeviceSummary::maxImageDimension2D);
  f("maxStorageBufferRange", &DeviceSummary::maxStorageBufferRange);
  f("maxComputeSharedMemorySize", &DeviceSummary::maxComputeSharedMemorySize);
  f("subgroupSize", &DeviceSummary::subgroupSize);
  f("timestampPeriodNs", &DeviceSummary::timestampPeriodNs);
  f("timestampsSupported", &DeviceSummary::timestampsSupported);
}

template <class F>
void members(Tag<SceneCounts>, F f) {
  f("lights", &SceneCounts::lights);
  f("instances", &SceneCounts::instances);
  f("materials", &SceneCounts::materials);
  f("meshes", &SceneCounts::meshes);
}

template <class F>
void members(Tag<LibraryModel>, F f) {
  f("name", &LibraryModel::name);
  f("bytes", &LibraryModel::bytes);
}

template <class F>
void members(Tag<ModelsList>, F f) {
  f("models", &ModelsList::models);
}

template <class F>
void members(Tag<Health>, F f) {
  f("status", &Health::status);
}

template <class F>
void members(Tag<Problem>, F f) {
  f("type", &Problem::type);
  f("title", &Problem::title);
  f("status", &Problem::status);
  f("detail", &Problem::detail);
  f("parameter", &Problem::parameter);
  f("pointer", &Problem::pointer);
  f("limit", &Problem::limit);
}

// JSON <-> struct through the member list.
template <class T>
void write(json& j, const T& v) {
  j = json::object();
  members(Tag<T>{}, [&](const char* name, auto member) { put(j, name, v.*member); });
}

template <class T>
void read(const json& j, T& v) {
  members(Tag<T>{}, [&](const char* name, auto member) { get(j, name, v.*member); });
}

// A patch applied to the whole: each present member replaces the whole's, and a nested patch
// (settings' sun) is applied member by member in turn.
template <class T, class P>
T applyPatch(T whole, const P& p);

template <class T, class U>
void patch(T& target, const std::optional<U>& value) {
  if (!value) return;
  if constexpr (std::is_same_v<T, U> || std::is_same_v<T, std::optional<U>>) {
    target = *value;  // (a whole's member the body may omit takes the patch's value too)
  } else {
    target = applyPatch(std::move(target), *value);
  }
}

template <class T, class P>
T applyPatch(T whole, const P& p) {
  patchMembers(Tag<P>{}, [&](const char*, auto wholeMember, auto patchMember) {
    patch(whole.*wholeMember, p.*patchMember);
  });
  return whole;
}

}  // namespace

Camera applied(Camera camera, const CameraPatch& p) { return applyPatch(std::move(camera), p); }
Settings applied(Settings settings, const SettingsPatch& p) {
  return applyPatch(std::move(settings), p);
}
Material applied(Material material, const MaterialPatch& p) {
  return applyPatch(std::move(material), p);
}
Light applied(Light light, const LightPatch& p) { return applyPatch(std::move(light), p); }

Light withId(const LightNew& l, uint64_t id) {
  Light out{id, l.position, l.radius, l.color, l.intensity, l.falloff};
  if (l.type) out.type = *l.type;
  if (l.attenuation) out.attenuation = *l.attenuation;
  if (l.direction) out.direction = *l.direction;
  if (l.innerConeAngle) out.innerConeAngle = *l.innerConeAngle;
  if (l.outerConeAngle) out.outerConeAngle = *l.outerConeAngle;
  out.castsShadows = l.castsShadows.value_or(false);
  return out;
}

#define MYRIAD_MEMBERWISE_JSON(Type)                                  \
  void to_json(json& j, const Type& v) { write(j, v); }               \
  void from_json(const json& j, Type& v) { read(j, v); }

MYRIAD_MEMBERWISE_JSON(Bounds)
MYRIAD_MEMBERWISE_JSON(Camera)
MYRIAD_MEMBERWISE_JSON(CameraPatch)
MYRIAD_MEMBERWISE_JSON(Sun)
MYRIAD_MEMBERWISE_JSON(SunPatch)
MYRIAD_MEMBERWISE_JSON(Environment)
MYRIAD_MEMBERWISE_JSON(EnvironmentPatch)
MYRIAD_MEMBERWISE_JSON(Shadows)
MYRIAD_MEMBERWISE_JSON(ShadowsPatch)
MYRIAD_MEMBERWISE_JSON(Fog)
MYRIAD_MEMBERWISE_JSON(FogPatch)
MYRIAD_MEMBERWISE_JSON(Settings)
MYRIAD_MEMBERWISE_JSON(SettingsPatch)
MYRIAD_MEMBERWISE_JSON(MaterialTexture)
MYRIAD_MEMBERWISE_JSON(Material)
MYRIAD_MEMBERWISE_JSON(MaterialPatch)
MYRIAD_MEMBERWISE_JSON(MaterialsList)
MYRIAD_MEMBERWISE_JSON(LightNew)
MYRIAD_MEMBERWISE_JSON(Light)
MYRIAD_MEMBERWISE_JSON(LightPatch)
MYRIAD_MEMBERWISE_JSON(LightsAdd)
MYRIAD_MEMBERWISE_JSON(LightsAdded)
MYRIAD_MEMBERWISE_JSON(LightsGenerate)
MYRIAD_MEMBERWISE_JSON(LightsGenerated)
MYRIAD_MEMBERWISE_JSON(LightsPage)
MYRIAD_MEMBERWISE_JSON(ModelSource)
MYRIAD_MEMBERWISE_JSON(LightsRecipe)
MYRIAD_MEMBERWISE_JSON(SnapshotLights)
MYRIAD_MEMBERWISE_JSON(Transform)
MYRIAD_MEMBERWISE_JSON(ObjectPatch)
MYRIAD_MEMBERWISE_JSON(ObjectsAdd)
MYRIAD_MEMBERWISE_JSON(ObjectsAdded)
MYRIAD_MEMBERWISE_JSON(Object)
MYRIAD_MEMBERWISE_JSON(ObjectsPage)
MYRIAD_MEMBERWISE_JSON(AssetMaterials)
MYRIAD_MEMBERWISE_JSON(Asset)
MYRIAD_MEMBERWISE_JSON(AssetsList)
MYRIAD_MEMBERWISE_JSON(FrameIntrinsics)
MYRIAD_MEMBERWISE_JSON(ObjectLabel)
MYRIAD_MEMBERWISE_JSON(Labels)
MYRIAD_MEMBERWISE_JSON(Clock)
MYRIAD_MEMBERWISE_JSON(ClockPatch)
MYRIAD_MEMBERWISE_JSON(SnapshotAsset)
MYRIAD_MEMBERWISE_JSON(SemanticClass)

MYRIAD_MEMBERWISE_JSON(ObjectAnimation)
MYRIAD_MEMBERWISE_JSON(SnapshotScene)
MYRIAD_MEMBERWISE_JSON(Snapshot)
MYRIAD_MEMBERWISE_JSON(SessionCreate)
MYRIAD_MEMBERWISE_JSON(ModelSummary)
MYRIAD_MEMBERWISE_JSON(ModelCamera)
MYRIAD_MEMBERWISE_JSON(ModelLights)
MYRIAD_MEMBERWISE_JSON(CameraSelect)
MYRIAD_MEMBERWISE_JSON(SessionCreated)
MYRIAD_MEMBERWISE_JSON(TokenCreate)
MYRIAD_MEMBERWISE_JSON(TokenCreated)
MYRIAD_MEMBERWISE_JSON(LightPick)
MYRIAD_MEMBERWISE_JSON(PassTiming)
MYRIAD_MEMBERWISE_JSON(FrameStats)
MYRIAD_MEMBERWISE_JSON(CullingStats)
MYRIAD_MEMBERWISE_JSON(PipelineStats)
MYRIAD_MEMBERWISE_JSON(LightShadowStats)
MYRIAD_MEMBERWISE_JSON(GpuMemory)
MYRIAD_MEMBERWISE_JSON(Limits)
MYRIAD_MEMBERWISE_JSON(DeviceSummary)
MYRIAD_MEMBERWISE_JSON(SceneCounts)
MYRIAD_MEMBERWISE_JSON(LibraryModel)
MYRIAD_MEMBERWISE_JSON(ModelsList)
MYRIAD_MEMBERWISE_JSON(Health)
MYRIAD_MEMBERWISE_JSON(Problem)

#undef MYRIAD_MEMBERWISE_JSON

// The types whose JSON nests members in objects of their own, or is an array.

void to_json(json& j, const Semantic& v) { j = v.name ? json(*v.name) : json(v.id); }
void from_json(const json& j, Semantic& v) {
  if (j.is_string()) {
    v = {0, j.get<std::string>()};
  } else {
    v = {j.get<uint64_t>(), std::nullopt};
  }
}

void to_json(json& j, const Range& v) { j = json::array({v.min, v.max}); }
void from_json(const json& j, Range& v) {
  j.at(0).get_to(v.min);
  j.at(1).get_to(v.max);
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

void to_json(json& j, const Stats& v) {
  j = {{"frame", orNull(v.frame)},
       {"pipeline", orNull(v.pipeline)},
       {"lights", {{"count", v.lightCount}, {"animated", v.lightsAnimated}}},
       {"culling", orNull(v.culling)},
       {"lightShadows", orNull(v.lightShadows)},
       {"gpuMemory", v.gpuMemory},
       {"frames", v.frames}};
}
void from_json(const json& j, Stats& v) {
  const json& frame = j.at("frame");
  v.frame = frame.is_null() ? std::nullopt : std::optional(frame.get<FrameStats>());
  const json& pipeline = j.at("pipeline");
  v.pipeline = pipeline.is_null() ? std::nullopt : std::optional(pipeline.get<PipelineStats>());
  get(j.at("lights"), "count", v.lightCount);
  get(j.at("lights"), "animated", v.lightsAnimated);
  const json& culling = j.at("culling");
  v.culling = culling.is_null() ? std::nullopt : std::optional(culling.get<CullingStats>());
  const json& shadows = j.at("lightShadows");
  v.lightShadows =
      shadows.is_null() ? std::nullopt : std::optional(shadows.get<LightShadowStats>());
  get(j, "gpuMemory", v.gpuMemory);
  get(j, "frames", v.frames);
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

}  // namespace myriad::protocol
