// The v1 bodies as plain C++ structs, shared by the server, the CLI and the tests, with
// nlohmann::json conversions (to_json/from_json, found by ADL: `body.get<Camera>()`, `json(x)`).
// No glm here: the CLI links this library and nothing else of the server.
//
// from_json assumes the JSON already passed its schema (validate.h): call it only after validate()
// or on bodies the server itself wrote. Optional members that are absent stay std::nullopt, and
// to_json leaves out what is nullopt, so a body survives the trip JSON -> struct -> JSON unchanged.
// A type names its members once: a new one beside its struct here (a members() overload and
// MYRIAD_PROTOCOL_MEMBERWISE, protocol/members.h), the older ones in types.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/members.h"

namespace myriad::protocol {

using Vec3 = std::array<double, 3>;   // [x, y, z] in scene units
using Color = std::array<double, 3>;  // linear RGB

struct Bounds {
  Vec3 min{};
  Vec3 max{};
};

struct Camera {
  Vec3 eye{};
  Vec3 target{};
  Vec3 up{0, 1, 0};
  double fovY = 60;  // degrees
  double near = 0.1;
  double far = 1000;
};

struct CameraPatch {
  std::optional<Vec3> eye, target, up;
  std::optional<double> fovY, near, far;
};
Camera applied(Camera camera, const CameraPatch& patch);

struct Sun {
  Vec3 direction{};  // the way the light travels (not normalized on the wire)
  Color color{};
  double intensity = 0;
};

struct SunPatch {
  std::optional<Vec3> direction;
  std::optional<Color> color;
  std::optional<double> intensity;
};

// The environment light (image-based lighting).
struct Environment {
  std::string mode = "none";  // "none" | "sky" | "hdr" (constants.h environment_modes::)
  double intensity = 1;
  double rotation = 0;        // radians about +Y (hdr)
  bool background = false;    // shown where no geometry is
  // Where the hdr image came from ("upload:NAME", "library:NAME"), sent by the server while the
  // session has one; a snapshot restores a library image by it. Not patchable.
  std::optional<std::string> source;
};

struct EnvironmentPatch {
  std::optional<std::string> mode;
  std::optional<double> intensity, rotation;
  std::optional<bool> background;
};

// Shadow maps.
struct Shadows {
  bool sun = false;         // the sun casts shadows
  uint32_t mapSize = 2048;  // the sun's map, texels across (defs.schema.json shadowMapSize)
  // Local lights asking for shadows that get a map in a frame, at most. The server always sends
  // it; a body may leave it out (a snapshot from before local shadows): the default then.
  std::optional<uint32_t> maxShadowedLights;
  // local_shadow_modes:: "none" | "maps" | "stochastic". The server always sends it; a body may
  // leave it out (a snapshot from before it): "maps" then.
  std::optional<std::string> local;
  // The sun's cascades, 1..4 (defs.schema.json sunCascades). The server always sends it; a body
  // may leave it out (a snapshot from before cascades): 4 then.
  std::optional<uint32_t> cascades;
};

struct ShadowsPatch {
  std::optional<bool> sun;
  std::optional<uint32_t> mapSize;
  std::optional<uint32_t> maxShadowedLights;
  std::optional<std::string> local;
  std::optional<uint32_t> cascades;
};

// Distance fog (aerial perspective): a surface d metres away keeps exp(-density * d) of its light
// and takes the rest from the fog's colour. Optional in a body (a snapshot from before fog): off.
struct Fog {
  double density = 0;          // per metre, 0 to 10 (defs.schema.json fogDensity); 0: off
  Color color{0.5, 0.6, 0.7};  // linear RGB (render::FogSettings' default)
};

struct FogPatch {
  std::optional<double> density;
  std::optional<Color> color;
};

struct Settings {
  Sun sun;
  std::vector<Sun> suns;  // more directional lights (a model's), at most kMaxExtraSuns
  Color ambient{};
  double exposure = 1;
  bool markers = false;
  // antialias_modes:: "none" | "fxaa" | "taa" | "ssaa". The server always sends it; a body may leave it out (a
  // snapshot saved before anti-aliasing existed), which restores as a new session starts: "fxaa".
  std::optional<std::string> antialias;
  std::string technique;  // "volumes" | "tiled" | "clustered" (constants.h technique_names::)
  bool animate = false;
  Color background{};
  Environment environment;
  Shadows shadows;
  Fog fog;
};

inline constexpr size_t kMaxExtraSuns = 3;

struct SettingsPatch {
  std::optional<SunPatch> sun;
  std::optional<std::vector<Sun>> suns;  // replaces them all
  std::optional<Color> ambient;
  std::optional<double> exposure;
  std::optional<bool> markers;
  std::optional<std::string> antialias;
  std::optional<std::string> technique;
  std::optional<bool> animate;
  std::optional<Color> background;
  std::optional<EnvironmentPatch> environment;
  std::optional<ShadowsPatch> shadows;
  std::optional<FogPatch> fog;
};
Settings applied(Settings settings, const SettingsPatch& patch);

// One texture a material uses (read-only: textures stay as the model file gave them).
struct MaterialTexture {
  std::string slot;   // kTextureSlots
  std::string image;  // the image's name in the model (a file name, or "*N" for embedded ones)
  uint32_t width = 0, height = 0;
  std::string wrapS, wrapT;          // kWrapModes
  std::string magFilter, minFilter;  // kFilters
  bool mipmaps = true;
};

struct Material {
  uint32_t id = 0;
  std::string name;
  Color baseColor{};
  double metallic = 0;
  double roughness = 1;
  double alpha = 1;
  Color emissive{};
  double emissiveStrength = 1;
  double normalScale = 1;
  double occlusionStrength = 1;
  std::string alphaMode = "opaque";  // kAlphaModes
  double alphaCutoff = 0.5;
  bool doubleSided = true;
  // KHR_materials_clearcoat, _sheen, _ior and _specular's factors. The server always sends them;
  // a body may leave them out (a snapshot from before they could be edited): restoring it then
  // gives the material the model file's own values.
  std::optional<double> clearcoat, clearcoatRoughness;
  std::optional<Color> sheenColor;
  std::optional<double> sheenRoughness, ior, specular;
  std::vector<MaterialTexture> textures;  // read-only
};

struct MaterialPatch {
  std::optional<Color> baseColor;
  std::optional<double> metallic, roughness, alpha;
  std::optional<Color> emissive;
  std::optional<double> emissiveStrength, normalScale, occlusionStrength;
  std::optional<std::string> alphaMode;
  std::optional<double> alphaCutoff;
  std::optional<bool> doubleSided;
  std::optional<double> clearcoat, clearcoatRoughness;
  std::optional<Color> sheenColor;
  std::optional<double> sheenRoughness, ior, specular;
};
Material applied(Material material, const MaterialPatch& patch);

struct MaterialsList {
  std::vector<Material> materials;
};

// A light as sent to POST .../lights: without its id. The members after falloff may be left out
// (a point light with the window falloff; a spot's defaults are glTF's).
struct LightNew {
  Vec3 position{};
  double radius = 1;
  Color color{};
  double intensity = 0;
  double falloff = 0;  // C in (r^2 - d^2) / (C d^2 + r^2)
  std::optional<std::string> type;         // light_types:: "point" (absent) | "spot"
  std::optional<std::string> attenuation;  // attenuations:: "window" (absent) | "inverse-square"
  std::optional<Vec3> direction;           // where a spot points; absent = [0, -1, 0]
  std::optional<double> innerConeAngle;    // radians; absent = 0
  std::optional<double> outerConeAngle;    // radians; absent = pi/4
  std::optional<bool> castsShadows;        // asks for a shadow map; absent = false
};

inline constexpr double kDefaultOuterConeAngle = 0.78539816339744831;  // pi/4, glTF's default

struct Light {
  uint64_t id = 0;
  Vec3 position{};
  double radius = 1;
  Color color{};
  double intensity = 0;
  double falloff = 0;
  std::string type{light_types::kPoint};
  std::string attenuation{attenuations::kWindow};
  Vec3 direction{0, -1, 0};
  double innerConeAngle = 0;
  double outerConeAngle = kDefaultOuterConeAngle;
  // Asks for a shadow map. The server always sends it; absent (a snapshot from before local
  // shadows) reads as false.
  std::optional<bool> castsShadows;
};
Light withId(const LightNew& light, uint64_t id);

struct LightPatch {
  std::optional<Vec3> position;
  std::optional<double> radius;
  std::optional<Color> color;
  std::optional<double> intensity, falloff;
  std::optional<std::string> type, attenuation;
  std::optional<Vec3> direction;
  std::optional<double> innerConeAngle, outerConeAngle;
  std::optional<bool> castsShadows;
};
Light applied(Light light, const LightPatch& patch);

struct LightsAdd {
  std::vector<LightNew> lights;
};

struct LightsAdded {
  std::vector<uint64_t> ids;
  uint64_t total = 0;
};

// [min, max] on the wire.
struct Range {
  double min = 0;
  double max = 0;
};

struct LightsGenerate {
  uint64_t count = 0;
  uint64_t seed = 0;
  std::optional<bool> replace;  // absent = true
  std::optional<Bounds> bounds;  // absent = the model's bounds, grown a little
  std::optional<Range> radius, intensity;
  std::optional<double> falloff;
  bool replaces() const { return replace.value_or(true); }
};

struct LightsGenerated {
  uint64_t total = 0;
};

struct LightsPage {
  uint64_t total = 0;
  uint64_t offset = 0;
  std::vector<Light> lights;
};

// PUT .../model as JSON.
struct ModelSource {
  std::string source;  // "builtin:default" | "library:NAME"
};

// How a session's lights were generated (POST .../lights/generate with its defaults, or the
// built-in scene's): a snapshot names them by this instead of listing them.
struct LightsRecipe {
  uint64_t count = 0;
  uint64_t seed = 0;
};

// A snapshot's lights: exactly one of the two (checkSnapshot).
struct SnapshotLights {
  std::optional<LightsRecipe> generated;
  std::optional<std::vector<LightNew>> list;  // in the session's order
};

// A member that may be null on the wire (an object's parent or material override): null reads
// as an empty value and writes back as null. In a patch, std::optional<Nullable<T>> tells "leave
// it" (absent) from "clear it" (null).
template <class T>
struct Nullable {
  std::optional<T> value;
  bool operator==(const Nullable&) const = default;
};
template <class T>
void to_json(nlohmann::json& j, const Nullable<T>& v) {
  j = v.value ? nlohmann::json(*v.value) : nlohmann::json(nullptr);
}
template <class T>
void from_json(const nlohmann::json& j, Nullable<T>& v) {
  if (j.is_null()) {
    v.value.reset();
  } else {
    v.value = j.get<T>();
  }
}

// Scenes (assets and objects): defs' transform, object*.schema.json, asset*.schema.json.
struct Transform {
  std::optional<Vec3> translation;
  std::optional<std::array<double, 4>> rotation;  // quaternion x, y, z, w
  std::optional<Vec3> scale;
  std::optional<std::array<double, 16>> matrix;   // column-major; not with the three above
};

// defs' objectAnimation: the clip an object plays (clip: an index, null for the rest pose; or
// clipName) and whether it loops. Responses also carry the duration and the asset's clip count.
struct ObjectAnimation {
  std::optional<Nullable<uint64_t>> clip;  // absent: unchanged (a patch) or the default, clip 0
  std::optional<std::string> clipName;
  std::optional<bool> loop;
  std::optional<double> duration;
  std::optional<uint64_t> clips;
};

// GET .../clock and PATCH .../clock (clock*.schema.json).
struct Clock {
  double time = 0.0;
  bool playing = true;
  double rate = 1.0;
  double duration = 0.0;
};
struct ClockPatch {
  std::optional<double> time;
  std::optional<bool> playing;
  std::optional<double> rate;
};

// defs' semantic: an object's semantic class as its client gave it, a small integer (0: none) or
// a class name, which the session maps to a class id of its own (first use takes the lowest id no
// class and no object's integer holds; SemanticClass). What was given reads back as given.
struct Semantic {
  uint64_t id = 0;
  std::optional<std::string> name;  // a class name: written as the string, `id` unused
  bool operator==(const Semantic&) const = default;
};
void to_json(nlohmann::json& j, const Semantic& v);
void from_json(const nlohmann::json& j, Semantic& v);

// defs' semanticClass: one class name and the id the session gave it (labels, snapshots).
struct SemanticClass {
  std::string name;
  uint64_t id = 0;
};

// POST .../objects' items (asset required) and PATCH .../objects/{oid} (any subset).
struct ObjectPatch {
  std::optional<std::string> name;
  std::optional<std::string> asset;
  std::optional<Transform> transform;
  std::optional<bool> visible;
  std::optional<Nullable<uint64_t>> parent;
  std::optional<Nullable<uint64_t>> material;
  std::optional<Semantic> semantic;
  std::optional<ObjectAnimation> animation;
  std::optional<Nullable<uint64_t>> node;  // an asset node by index; null: the whole asset
  std::optional<std::string> nodeName;     // or by name (the first of that name)
  std::optional<bool> subtree;  // with a node: also the nodes below it (default) or its own only
  std::optional<bool> tree;     // POST only: the asset's node tree as objects under this one
};
using ObjectNew = ObjectPatch;

struct ObjectsAdd {
  std::vector<ObjectNew> objects;
};

struct ObjectsAdded {
  std::vector<uint64_t> ids;
  uint64_t total = 0;
};

struct Object {
  uint64_t id = 0;
  std::string name;
  std::string asset;
  Transform transform;
  bool visible = true;
  Nullable<uint64_t> parent;
  Nullable<uint64_t> material;
  Semantic semantic;
  uint64_t instances = 0;
  std::optional<Bounds> bounds;  // absent when it draws nothing
  std::optional<ObjectAnimation> animation;  // present for an asset with animation clips
  std::optional<uint64_t> node;              // present for an object of one asset node
  std::optional<std::string> nodeName;
  std::optional<bool> subtree;               // present with node
};

struct ObjectsPage {
  uint64_t total = 0;
  uint64_t offset = 0;
  uint64_t nextObjectId = 1;
  std::vector<Object> objects;
};

struct AssetMaterials {
  uint64_t first = 0;
  uint64_t count = 0;
};

struct Asset {
  std::string id;
  std::string source;
  uint64_t bytes = 0;
  uint64_t meshes = 0;
  uint64_t instances = 0;
  AssetMaterials materials;
  uint64_t images = 0;
  std::optional<Bounds> bounds;
  uint64_t objects = 0;
  std::optional<std::vector<std::string>> ignoredExtensions;  // as ModelSummary's
};

struct AssetsList {
  std::vector<Asset> assets;
};

// GET .../labels.
struct FrameIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  uint64_t width = 0, height = 0;
  double near = 0, far = 0;
};
struct ObjectLabel {
  uint64_t id = 0;
  uint64_t semantic = 0;
  uint64_t pixels = 0;
  std::array<uint64_t, 4> box{};  // [x0, y0, x1, y1)
  std::optional<Bounds> bounds;
  std::optional<uint64_t> totalPixels;  // with nothing in front of it (scene/coverage.h)
};
struct Labels {
  uint64_t width = 0;
  uint64_t height = 0;
  FrameIntrinsics intrinsics;
  std::array<std::array<double, 4>, 4> worldFromCamera{};  // rows
  std::vector<ObjectLabel> objects;
  std::optional<std::vector<SemanticClass>> classes;  // the session's class names, by id
};

// A snapshot's scene: the assets by id and source, in order, every object, and the next id.
struct SnapshotAsset {
  std::string id;
  std::string source;
};
struct SnapshotScene {
  std::vector<SnapshotAsset> assets;
  std::vector<Object> objects;
  uint64_t nextObjectId = 1;
  std::optional<std::vector<SemanticClass>> classes;  // by id; absent in older snapshots
};

// GET .../snapshot: everything a session holds but the model's bytes, as one document that
// POST /v1/sessions and PUT .../snapshot restore.
struct Snapshot {
  uint64_t version = 1;
  ModelSource model;
  Camera camera;
  Settings settings;
  std::vector<Material> materials;  // by id; names as the model has them
  SnapshotLights lights;
  std::optional<SnapshotScene> scene;  // absent in snapshots from before scenes
};

// POST /v1/sessions.
struct SessionCreate {
  std::optional<std::string> model;  // absent = "builtin:default"
  std::optional<Snapshot> snapshot;  // a session restored from a snapshot (instead of model)
};

// A camera the model file defines (model.cameras), placed by its node.
struct ModelCamera {
  uint64_t index = 0;  // what POST .../camera/select takes
  std::string name;
  std::string type;    // "perspective" | "orthographic"
  double yfov = 0;     // radians (perspective)
  std::optional<double> aspectRatio;
  double znear = 0;
  std::optional<double> zfar;  // absent: infinite
  Vec3 position{};
  Vec3 direction{};  // where it looks (the node's -Z)
  Vec3 up{};         // the node's +Y
};

// The model file's lights (model.lights): what arrived, and what did not fit.
struct ModelLights {
  uint64_t point = 0;
  uint64_t spot = 0;
  uint64_t directional = 0;         // in the file
  uint64_t directionalDropped = 0;  // beyond kMaxExtraSuns, the dimmest: not used
};

struct ModelSummary {
  std::string source;  // "builtin:default" | "library:NAME" | "upload:FILENAME"
  uint64_t meshes = 0;
  uint64_t instances = 0;
  uint64_t materials = 0;
  Bounds bounds;
  std::vector<ModelCamera> cameras;
  std::optional<ModelLights> lights;  // the server always sends it
  // glTF extensions the file uses that the server does not honour; absent when none.
  std::optional<std::vector<std::string>> ignoredExtensions;
};

// POST .../camera/select.
struct CameraSelect {
  uint64_t modelCamera = 0;
};

struct SessionState {
  std::string id;  // "s-" + 16 hex digits
  ModelSummary model;
  Camera camera;
  Settings settings;
  uint64_t lightCount = 0;  // "lights": {"count": N}
  uint64_t expiresInSeconds = 0;
};

struct SessionCreated {
  std::string id;
  std::string token;  // 64 hex digits
  uint64_t expiresInSeconds = 0;
  SessionState session;
};

// POST .../tokens: a token of another role for the session (roles::kViewer).
struct TokenCreate {
  std::string role;
  std::optional<uint64_t> ttlSeconds;  // default kDefaultViewerTokenSeconds
};

struct TokenCreated {
  std::string token;  // 64 hex digits
  std::string role;
  uint64_t expiresInSeconds = 0;
  std::string link;  // "/#session=ID&token=TOKEN": the web client with this token
};

// GET .../lights/pick: the light whose marker is under a pixel; absent members when none is.
struct LightPick {
  std::optional<Light> light;
  std::optional<double> distance;  // pixels
  uint64_t candidates = 0;
};

struct PassTiming {
  std::string name;
  double ms = 0;
};

struct FrameStats {
  std::vector<PassTiming> passes;
  double totalGpuMs = 0;
  double readbackMs = 0;
  double encodeMs = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  std::string technique;
  std::string target;
};

struct CullingStats {
  uint64_t tilesOverflowed = 0;
  uint64_t tileLightsDropped = 0;
  uint64_t clusterLightsDropped = 0;
  uint64_t listEntries = 0;
  uint64_t activeClusters = 0;
  uint64_t mostLightsInList = 0;
};

struct GpuMemory {
  uint64_t lightBytes = 0;
  uint64_t listBytes = 0;
  uint64_t sceneBytes = 0;
};

// The last frame's local-light shadows (render::Frame::LightShadows, indices made ids).
struct LightShadowStats {
  std::vector<uint64_t> lights;  // ids of the lights that had a shadow map, most important first
  uint64_t requested = 0;        // lights asking for one that reach into the view
  uint64_t dropped = 0;          // of those, past maxShadowedLights: drawn unshadowed
};

// Where the session's recent frames spent their time: medians (milliseconds) over its last
// frames of the last frame's size (stats' `pipeline`). Optional members: not measured (no GPU
// timestamps; no stream part written).
struct PipelineStats {
  uint64_t frames = 0;             // frames the medians are over
  double queueMs = 0;              // waiting for the render thread
  double recordMs = 0;             // recording and submitting (render thread)
  std::optional<double> gpuMs;     // first to last GPU timestamp
  std::optional<double> gpuIdleMs; // the GPU idle before it started
  double fenceWaitMs = 0;          // the render thread blocked on its fence
  double copyMs = 0;               // the render thread copying its pixels (0: encoded in place)
  double answerMs = 0;             // submission to its result handed to the worker
  std::optional<double> waitMs;    // the worker waiting for it
  double encodeMs = 0;
  uint64_t parts = 0;              // stream parts the send medians are over
  std::optional<double> sendMs;    // writing a stream part
  std::optional<double> intervalMs;  // between a stream's parts
};

struct Stats {
  std::optional<FrameStats> frame;      // null before the session's first frame
  std::optional<PipelineStats> pipeline;  // null before the first frame
  std::optional<LightShadowStats> lightShadows;  // null before the first frame
  uint64_t lightCount = 0;              // "lights": {"count", "animated"}
  bool lightsAnimated = false;
  std::optional<CullingStats> culling;  // null before the first frame
  GpuMemory gpuMemory;
  uint64_t frames = 0;
};

struct Limits {
  uint32_t maxResolution = 0;
  uint64_t maxQueuedFrames = 0;
  uint64_t maxSessions = 0;
  uint64_t maxLightsPerSession = 0;
  uint64_t maxObjectsPerSession = 0;
  uint64_t maxUploadBytes = 0;
  uint64_t maxBodyBytes = 0;
  uint64_t maxStreams = 0;
  std::optional<uint64_t> maxStreamsPerSession;  // absent from servers before it existed
  uint64_t maxRequestsInFlight = 0;
  uint64_t sessionIdleSeconds = 0;
  std::optional<uint64_t> maxMemoryBytes;  // absent from servers before it existed
  std::optional<uint64_t> maxFrameSeconds;  // likewise
  std::optional<uint64_t> maxEventStreamsPerSession;  // likewise
  std::optional<uint64_t> maxEventStreams;  // likewise
  std::optional<uint64_t> maxFrameTargets;  // likewise
};

struct DeviceSummary {
  std::string name;
  std::string type;  // "discrete-gpu" | "integrated-gpu" | "virtual-gpu" | "cpu" | "other"
  std::string driverName;
  std::string driverInfo;
  std::string apiVersion;
  uint32_t vendorId = 0;
  uint32_t deviceId = 0;
  uint32_t index = 0;
  bool isCpu = false;
  uint32_t maxImageDimension2D = 0;
  uint64_t maxStorageBufferRange = 0;
  uint32_t maxComputeSharedMemorySize = 0;
  uint32_t subgroupSize = 0;
  double timestampPeriodNs = 0;
  bool timestampsSupported = false;
};

struct SceneCounts {
  uint64_t lights = 0;
  uint64_t instances = 0;
  uint64_t materials = 0;
  uint64_t meshes = 0;
};

struct Info {
  std::string serverName = "myriad-server";
  std::string serverVersion;
  DeviceSummary device;
  Limits limits;
  uint64_t openSessions = 0;  // "sessions": {"open": N}
  uint64_t gpuMemoryBytes = 0;
  bool validationEnabled = false;
  uint64_t validationMessages = 0;
  SceneCounts scene;  // the built-in scene of GET /v1/frame
  std::vector<std::string> targets;
  std::vector<std::string> techniques;
  std::string defaultTechnique;
  std::vector<std::string> formats;
  bool apiKeyRequired = false;
};

struct LibraryModel {
  std::string name;  // relative to --models, '/' separators
  uint64_t bytes = 0;
};

struct ModelsList {
  std::vector<LibraryModel> models;
};

struct Health {
  std::string status = "ok";
};

// RFC 9457 problem details (application/problem+json).
struct Problem {
  std::string type;  // https://myriad.dev/problems/NAME (problemTypeUri() in constants.h)
  std::string title;
  int status = 500;
  std::string detail;
  std::optional<std::string> parameter;  // the query parameter to blame
  std::optional<std::string> pointer;    // JSON Pointer into the request body
  std::optional<std::string> limit;      // the limit exceeded, as named in /v1/info limits
};

#define MYRIAD_PROTOCOL_JSON(Type)                  \
  void to_json(nlohmann::json& j, const Type& v);   \
  void from_json(const nlohmann::json& j, Type& v)

MYRIAD_PROTOCOL_JSON(Bounds);
MYRIAD_PROTOCOL_JSON(Camera);
MYRIAD_PROTOCOL_JSON(CameraPatch);
MYRIAD_PROTOCOL_JSON(Sun);
MYRIAD_PROTOCOL_JSON(SunPatch);
MYRIAD_PROTOCOL_JSON(Environment);
MYRIAD_PROTOCOL_JSON(EnvironmentPatch);
MYRIAD_PROTOCOL_JSON(Shadows);
MYRIAD_PROTOCOL_JSON(ShadowsPatch);
MYRIAD_PROTOCOL_JSON(Fog);
MYRIAD_PROTOCOL_JSON(FogPatch);
MYRIAD_PROTOCOL_JSON(Settings);
MYRIAD_PROTOCOL_JSON(SettingsPatch);
MYRIAD_PROTOCOL_JSON(MaterialTexture);
MYRIAD_PROTOCOL_JSON(Material);
MYRIAD_PROTOCOL_JSON(MaterialPatch);
MYRIAD_PROTOCOL_JSON(MaterialsList);
MYRIAD_PROTOCOL_JSON(LightNew);
MYRIAD_PROTOCOL_JSON(Light);
MYRIAD_PROTOCOL_JSON(LightPatch);
MYRIAD_PROTOCOL_JSON(LightsAdd);
MYRIAD_PROTOCOL_JSON(LightsAdded);
MYRIAD_PROTOCOL_JSON(Range);
MYRIAD_PROTOCOL_JSON(LightsGenerate);
MYRIAD_PROTOCOL_JSON(LightsGenerated);
MYRIAD_PROTOCOL_JSON(LightsPage);
MYRIAD_PROTOCOL_JSON(ModelSource);
MYRIAD_PROTOCOL_JSON(LightsRecipe);
MYRIAD_PROTOCOL_JSON(SnapshotLights);
MYRIAD_PROTOCOL_JSON(Transform);
MYRIAD_PROTOCOL_JSON(ObjectAnimation);
MYRIAD_PROTOCOL_JSON(Clock);
MYRIAD_PROTOCOL_JSON(ClockPatch);
MYRIAD_PROTOCOL_JSON(ObjectPatch);
MYRIAD_PROTOCOL_JSON(ObjectsAdd);
MYRIAD_PROTOCOL_JSON(ObjectsAdded);
MYRIAD_PROTOCOL_JSON(Object);
MYRIAD_PROTOCOL_JSON(ObjectsPage);
MYRIAD_PROTOCOL_JSON(AssetMaterials);
MYRIAD_PROTOCOL_JSON(Asset);
MYRIAD_PROTOCOL_JSON(AssetsList);
MYRIAD_PROTOCOL_JSON(FrameIntrinsics);
MYRIAD_PROTOCOL_JSON(ObjectLabel);
MYRIAD_PROTOCOL_JSON(Labels);
MYRIAD_PROTOCOL_JSON(SemanticClass);
MYRIAD_PROTOCOL_JSON(SnapshotAsset);
MYRIAD_PROTOCOL_JSON(SnapshotScene);
MYRIAD_PROTOCOL_JSON(Snapshot);
MYRIAD_PROTOCOL_JSON(SessionCreate);
MYRIAD_PROTOCOL_JSON(ModelCamera);
MYRIAD_PROTOCOL_JSON(ModelLights);
MYRIAD_PROTOCOL_JSON(CameraSelect);
MYRIAD_PROTOCOL_JSON(ModelSummary);
MYRIAD_PROTOCOL_JSON(SessionState);
MYRIAD_PROTOCOL_JSON(SessionCreated);
MYRIAD_PROTOCOL_JSON(TokenCreate);
MYRIAD_PROTOCOL_JSON(TokenCreated);
MYRIAD_PROTOCOL_JSON(LightPick);
MYRIAD_PROTOCOL_JSON(PassTiming);
MYRIAD_PROTOCOL_JSON(FrameStats);
MYRIAD_PROTOCOL_JSON(CullingStats);
MYRIAD_PROTOCOL_JSON(LightShadowStats);
MYRIAD_PROTOCOL_JSON(GpuMemory);
MYRIAD_PROTOCOL_JSON(Stats);
MYRIAD_PROTOCOL_JSON(Limits);
MYRIAD_PROTOCOL_JSON(DeviceSummary);
MYRIAD_PROTOCOL_JSON(SceneCounts);
MYRIAD_PROTOCOL_JSON(Info);
MYRIAD_PROTOCOL_JSON(LibraryModel);
MYRIAD_PROTOCOL_JSON(ModelsList);
MYRIAD_PROTOCOL_JSON(Health);
MYRIAD_PROTOCOL_JSON(Problem);

#undef MYRIAD_PROTOCOL_JSON

}  // namespace myriad::protocol
