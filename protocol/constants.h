// Names both sides of the v1 protocol share: routes, headers, problem types, limits, schema names
// and fixed values of the formats. A string used by the server and by a client belongs here.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace myriad::protocol {

// Route templates; {id}, {mid}, {lid}, {aid} and {oid} are path segments (session id, material id,
// light id, asset id, object id).
namespace routes {
inline constexpr std::string_view kHealth = "/v1/health";
inline constexpr std::string_view kReady = "/v1/ready";
inline constexpr std::string_view kInfo = "/v1/info";
inline constexpr std::string_view kFrame = "/v1/frame";
inline constexpr std::string_view kModels = "/v1/models";
inline constexpr std::string_view kMetrics = "/metrics";
inline constexpr std::string_view kSessions = "/v1/sessions";
inline constexpr std::string_view kSession = "/v1/sessions/{id}";
inline constexpr std::string_view kSessionModel = "/v1/sessions/{id}/model";
inline constexpr std::string_view kSessionCamera = "/v1/sessions/{id}/camera";
inline constexpr std::string_view kSessionCameraFrame = "/v1/sessions/{id}/camera/frame";
inline constexpr std::string_view kSessionCameraSelect = "/v1/sessions/{id}/camera/select";
inline constexpr std::string_view kSessionSettings = "/v1/sessions/{id}/settings";
inline constexpr std::string_view kSessionEnvironment = "/v1/sessions/{id}/environment";
inline constexpr std::string_view kSessionMaterials = "/v1/sessions/{id}/materials";
inline constexpr std::string_view kSessionMaterial = "/v1/sessions/{id}/materials/{mid}";
inline constexpr std::string_view kSessionLights = "/v1/sessions/{id}/lights";
inline constexpr std::string_view kSessionLight = "/v1/sessions/{id}/lights/{lid}";
inline constexpr std::string_view kSessionLightsGenerate = "/v1/sessions/{id}/lights/generate";
inline constexpr std::string_view kSessionFrame = "/v1/sessions/{id}/frame";
inline constexpr std::string_view kSessionStream = "/v1/sessions/{id}/stream";
inline constexpr std::string_view kSessionStats = "/v1/sessions/{id}/stats";
inline constexpr std::string_view kSessionEvents = "/v1/sessions/{id}/events";  // text/event-stream
inline constexpr std::string_view kSessionSnapshot = "/v1/sessions/{id}/snapshot";
inline constexpr std::string_view kSessionTokens = "/v1/sessions/{id}/tokens";  // viewer tokens
inline constexpr std::string_view kSessionLightsPick = "/v1/sessions/{id}/lights/pick";
inline constexpr std::string_view kSessionAssets = "/v1/sessions/{id}/assets";
inline constexpr std::string_view kSessionAsset = "/v1/sessions/{id}/assets/{aid}";
inline constexpr std::string_view kSessionObjects = "/v1/sessions/{id}/objects";
inline constexpr std::string_view kSessionObject = "/v1/sessions/{id}/objects/{oid}";
inline constexpr std::string_view kSessionLabels = "/v1/sessions/{id}/labels";
// The scene clock: play, pause, seek, rate of the objects' animation clips.
inline constexpr std::string_view kSessionClock = "/v1/sessions/{id}/clock";
inline constexpr std::string_view kOpenApi = "/v1/openapi.json";  // this API as OpenAPI 3.1
inline constexpr std::string_view kWebRoot = "/";                 // the web client's page
inline constexpr std::string_view kWebFile = "/web/{file}";       // and its other files
}  // namespace routes

// A route template with {name} replaced by `value` (every occurrence), e.g.
// expandRoute(routes::kSessionCamera, "id", "s-0123456789abcdef").
std::string expandRoute(std::string_view route, std::string_view name, std::string_view value);

// Schema names for validate() (protocol/schemas/NAME.schema.json).
namespace schema_names {
inline constexpr std::string_view kSessionCreate = "session-create";
inline constexpr std::string_view kSnapshot = "snapshot";
inline constexpr std::string_view kSessionCreated = "session-created";
inline constexpr std::string_view kSessionState = "session-state";
inline constexpr std::string_view kModelSource = "model-source";
inline constexpr std::string_view kCamera = "camera";
inline constexpr std::string_view kCameraPatch = "camera-patch";
inline constexpr std::string_view kCameraSelect = "camera-select";
inline constexpr std::string_view kSettings = "settings";
inline constexpr std::string_view kSettingsPatch = "settings-patch";
inline constexpr std::string_view kMaterial = "material";
inline constexpr std::string_view kMaterialPatch = "material-patch";
inline constexpr std::string_view kMaterialsList = "materials-list";
inline constexpr std::string_view kLight = "light";
inline constexpr std::string_view kLightNew = "light-new";
inline constexpr std::string_view kLightPatch = "light-patch";
inline constexpr std::string_view kLightsAdd = "lights-add";
inline constexpr std::string_view kLightsAdded = "lights-added";
inline constexpr std::string_view kLightsGenerate = "lights-generate";
inline constexpr std::string_view kLightsGenerated = "lights-generated";
inline constexpr std::string_view kLightsPage = "lights-page";
inline constexpr std::string_view kStats = "stats";
inline constexpr std::string_view kInfo = "info";
inline constexpr std::string_view kModelsList = "models-list";
inline constexpr std::string_view kProblem = "problem";
inline constexpr std::string_view kHealth = "health";
inline constexpr std::string_view kTokenCreate = "token-create";
inline constexpr std::string_view kTokenCreated = "token-created";
inline constexpr std::string_view kLightPick = "light-pick";
inline constexpr std::string_view kAsset = "asset";
inline constexpr std::string_view kAssetsList = "assets-list";
inline constexpr std::string_view kObject = "object";
inline constexpr std::string_view kObjectNew = "object-new";
inline constexpr std::string_view kObjectPatch = "object-patch";
inline constexpr std::string_view kObjectsAdd = "objects-add";
inline constexpr std::string_view kObjectsAdded = "objects-added";
inline constexpr std::string_view kObjectsPage = "objects-page";
inline constexpr std::string_view kLabels = "labels";
inline constexpr std::string_view kClock = "clock";
inline constexpr std::string_view kClockPatch = "clock-patch";
}  // namespace schema_names

// Roles of a session's tokens: the token POST /v1/sessions returns is the owner's (everything);
// POST .../tokens makes viewer tokens, which may GET (read the session, watch its frames and
// stream) and nothing else.
namespace roles {
inline constexpr std::string_view kOwner = "owner";
inline constexpr std::string_view kViewer = "viewer";
}  // namespace roles
inline constexpr uint64_t kDefaultViewerTokenSeconds = 3600;
// A session holds at most this many viewer tokens; a new one beyond replaces the one that
// expires first (bounded memory and state file).
inline constexpr size_t kMaxViewerTokens = 32;

// Problem types: the last segment of https://myriad.dev/problems/NAME.
namespace problems {
inline constexpr std::string_view kTypePrefix = "https://myriad.dev/problems/";
inline constexpr std::string_view kInvalidParameter = "invalid-parameter";    // 400, parameter
inline constexpr std::string_view kUnknownParameter = "unknown-parameter";    // 400, parameter
inline constexpr std::string_view kInvalidBody = "invalid-body";              // 400, pointer
inline constexpr std::string_view kBadRequest = "bad-request";                // 400/413/414
inline constexpr std::string_view kUnauthorized = "unauthorized";             // 401
inline constexpr std::string_view kForbidden = "forbidden";                   // 403
inline constexpr std::string_view kNotFound = "not-found";                    // 404
inline constexpr std::string_view kMethodNotAllowed = "method-not-allowed";   // 405, Allow
inline constexpr std::string_view kUnsupportedMediaType = "unsupported-media-type";  // 415
inline constexpr std::string_view kConflict = "conflict";                    // 409
inline constexpr std::string_view kPreconditionFailed = "precondition-failed";  // 412, ETag
inline constexpr std::string_view kModelRejected = "model-rejected";          // 422
inline constexpr std::string_view kEnvironmentRejected = "environment-rejected";  // 422
inline constexpr std::string_view kLimitExceeded = "limit-exceeded";          // 413/429, limit
inline constexpr std::string_view kServerBusy = "server-busy";                // 503, Retry-After
inline constexpr std::string_view kRenderFailed = "render-failed";            // 500
inline constexpr std::string_view kInternalError = "internal-error";          // 500
inline constexpr std::array<std::string_view, 17> kAll = {
    kInvalidParameter, kUnknownParameter, kInvalidBody,     kBadRequest,     kUnauthorized,
    kForbidden,        kNotFound,         kMethodNotAllowed, kUnsupportedMediaType,
    kConflict,         kPreconditionFailed, kModelRejected, kEnvironmentRejected,
    kLimitExceeded,    kServerBusy,       kRenderFailed,    kInternalError};
}  // namespace problems

// "invalid-body" -> "https://myriad.dev/problems/invalid-body".
std::string problemTypeUri(std::string_view name);
// The reverse: the NAME of a problem type URI, or "" when it is not one of ours.
std::string_view problemTypeName(std::string_view typeUri);

// Limits, by their names in GET /v1/info "limits" and in problems' "limit" member.
namespace limits {
inline constexpr std::string_view kMaxResolution = "maxResolution";              // --max-resolution
inline constexpr std::string_view kMaxQueuedFrames = "maxQueuedFrames";          // --max-queued-frames
inline constexpr std::string_view kMaxSessions = "maxSessions";                  // --max-sessions
inline constexpr std::string_view kMaxLightsPerSession = "maxLightsPerSession";  // --max-lights
inline constexpr std::string_view kMaxUploadBytes = "maxUploadBytes";            // --max-upload-bytes
inline constexpr std::string_view kMaxBodyBytes = "maxBodyBytes";                // --max-body-bytes
inline constexpr std::string_view kMaxStreams = "maxStreams";                    // --max-streams
inline constexpr std::string_view kMaxStreamsPerSession = "maxStreamsPerSession";  // --max-streams-per-session
inline constexpr std::string_view kMaxEventStreamsPerSession = "maxEventStreamsPerSession";  // fixed: 6
inline constexpr std::string_view kMaxEventStreams = "maxEventStreams";  // fixed: 12
inline constexpr std::string_view kMaxRequestsInFlight = "maxRequestsInFlight";  // --max-requests
inline constexpr std::string_view kSessionIdleSeconds = "sessionIdleSeconds";    // --session-idle-seconds
inline constexpr std::string_view kMaxObjectsPerSession = "maxObjectsPerSession";  // --max-objects
inline constexpr std::string_view kMaxAssetsPerSession = "maxAssetsPerSession";    // fixed: 64
inline constexpr std::string_view kMaxFrameSeconds = "maxFrameSeconds";            // --max-frame-seconds
inline constexpr std::string_view kMaxMemoryBytes = "maxMemoryBytes";              // --max-memory
inline constexpr std::string_view kMaxFrameTargets = "maxFrameTargets";  // fixed: query::kMaxFrameTargets
}  // namespace limits

// Headers.
namespace headers {
inline constexpr std::string_view kAuthorization = "Authorization";  // "Bearer TOKEN"
inline constexpr std::string_view kBearerPrefix = "Bearer ";
inline constexpr std::string_view kChannels = "X-Myriad-Channels";    // raw: "x,y,z"
inline constexpr std::string_view kWidth = "X-Myriad-Width";          // raw
inline constexpr std::string_view kHeight = "X-Myriad-Height";        // raw
inline constexpr std::string_view kTarget = "X-Myriad-Target";        // raw
inline constexpr std::string_view kTechnique = "X-Myriad-Technique";  // every frame
// Every frame: the camera's pinhole intrinsics and near/far, and its pose (reference.md "Camera
// of a frame"), as JSON.
inline constexpr std::string_view kIntrinsics = "X-Myriad-Intrinsics";
inline constexpr std::string_view kPose = "X-Myriad-Pose";
inline constexpr std::string_view kDepth = "X-Myriad-Depth";  // raw depth: "z" or "distance"
inline constexpr std::string_view kDtype = "X-Myriad-Dtype";  // raw: "float32", or "uint32" (labels)
inline constexpr std::string_view kSpace = "X-Myriad-Space";  // raw position, normal: "world" or "camera"
inline constexpr std::string_view kFrameSequence = "X-Myriad-Frame";  // each stream part
// Session frames: the animation time shown (seconds) and the session version shown.
inline constexpr std::string_view kFrameTime = "X-Myriad-Time";
inline constexpr std::string_view kFrameVersion = "X-Myriad-Version";
// format=png16 of depth: metres per unit of the 16-bit values (0.001: millimetres).
inline constexpr std::string_view kDepthScale = "X-Myriad-Depth-Scale";
// format=npz and exr: the targets the file holds, in order ("final,depth,normal").
inline constexpr std::string_view kTargets = "X-Myriad-Targets";
// A stream part rendered while the session changes (?interactive=): its render scale ("0.5")
inline constexpr std::string_view kInteractive = "X-Myriad-Interactive";
// On a change (PUT/PATCH camera, PATCH settings or a material): "end" says it is the last of an
// interaction (a drag or a slider released), so interactive streams send the still at once.
inline constexpr std::string_view kInteraction = "X-Myriad-Interaction";
inline constexpr std::string_view kInteractionEnd = "end";
inline constexpr std::string_view kNode = "X-Myriad-Node";  // every response, with --node-id
inline constexpr std::string_view kVideoCodec = "X-Myriad-Codec";  // video stream: WebCodecs codec
inline constexpr std::string_view kServerTiming = "Server-Timing";
inline constexpr std::string_view kRetryAfter = "Retry-After";
inline constexpr std::string_view kAllow = "Allow";
inline constexpr std::string_view kLocation = "Location";  // 201: the new session's URL
// Session resources: the session's version as an entity tag (every answer of a session route);
// If-Match on an edit makes it conditional (412 precondition-failed when the session changed).
inline constexpr std::string_view kETag = "ETag";
inline constexpr std::string_view kIfMatch = "If-Match";
// Every response: the request's id, the client's own (1-128 of A-Z a-z 0-9 . _ : -) or one made
// for it; the access log names it.
inline constexpr std::string_view kRequestId = "X-Request-Id";
}  // namespace headers

// Query parameters with meaning on both sides.
namespace query {
inline constexpr std::string_view kToken = "token";  // for <img>, which cannot send headers
inline constexpr uint32_t kMaxLightsPageLimit = 1000;
inline constexpr uint32_t kDefaultLightsPageLimit = 100;
inline constexpr uint32_t kMaxObjectsPageLimit = 1000;
// GET .../frame?depth=z|distance: raw depth's convention.
inline constexpr std::string_view kDepthConvention = "depth";  // names-once: a query parameter
// GET .../frame?space=world|camera: raw position and normal in world or camera space.
inline constexpr std::string_view kSpace = "space";
// GET .../frame?target=a,b,c (format npz or exr): at most this many targets, each once.
inline constexpr size_t kMaxFrameTargets = 8;
// GET .../frame?compression= (PNG: encode/png.h) and ?precision= (EXR float channels).
inline constexpr std::string_view kCompression = "compression";
inline constexpr std::string_view kPrecision = "precision";
inline constexpr std::array<std::string_view, 3> kPngCompressions = {"none", "fast", "small"};
inline constexpr std::array<std::string_view, 2> kExrPrecisions = {"float", "half"};
inline constexpr uint32_t kDefaultObjectsPageLimit = 100;
inline constexpr uint32_t kMinFps = 1;
inline constexpr uint32_t kMaxFps = 240;  // a 240 Hz display; the GPU machine renders 1080p faster
inline constexpr uint32_t kDefaultFps = 15;
inline constexpr uint32_t kMinQuality = 1;
inline constexpr uint32_t kMaxQuality = 100;
inline constexpr uint32_t kMinBitrateKbps = 50;     // video streams' bitrate, kbit/s
// Streams: ?interactive=N, the frames a second to hold while the session changes (0: off).
inline constexpr uint32_t kMaxInteractiveFps = 60;
inline constexpr uint32_t kMaxBitrateKbps = 100000;
// GET .../frame?time=T and the scene clock's time: seconds from 0 to this.
inline constexpr double kMaxFrameTime = 1e6;
// The scene clock's rate: clock seconds per wall second, -kMaxClockRate..kMaxClockRate.
inline constexpr double kMaxClockRate = 64.0;
}  // namespace query

// Video streams (GET .../stream?codec=): the codecs, and for each (same order) the codec string
// WebCodecs' VideoDecoder takes for it (VP9: profile 0, level 1.0, 8 bits; H.264: this prefix,
// Constrained Baseline, then the level in hex, which depends on size and fps).
inline constexpr std::array<std::string_view, 3> kVideoCodecs = {"vp8", "vp9", "h264"};
inline constexpr std::array<std::string_view, 2> kWebCodecsCodecs = {"vp8", "vp09.00.10.08"};
inline constexpr std::string_view kWebCodecsH264Prefix = "avc1.42C0";
inline constexpr std::string_view kVideoStreamContentType = "application/x-myriad-video";
// ?container=: how a video stream's frames are framed (same order as encode::VideoContainer):
// Myriad's own chunks (the default for vp8 and vp9), live WebM (vp8, vp9) or fragmented MP4
// (h264, its default), with their Content-Types (kVideoStreamContentType for "myriad").
inline constexpr std::array<std::string_view, 3> kVideoContainers = {"myriad", "webm", "mp4"};
inline constexpr std::string_view kWebmContentType = "video/webm";
inline constexpr std::string_view kMp4ContentType = "video/mp4";
// The body of a video stream: chunks, each a header of kHeaderBytes then `payload bytes` of the
// codec's bitstream (one frame). The header, little-endian:
//   0 u32 payload bytes   4 u8 kind   5..7 zero   8 u16 width   10 u16 height
//   12 u32 frame sequence   16 u64 timestamp (microseconds since the stream began)
//   24 u64 session version shown   32 f64 animation time (s)   40 u32 encode microseconds
//   44 u32 zero
namespace video_chunk {
inline constexpr size_t kHeaderBytes = 48;
inline constexpr uint8_t kKey = 1;        // a key frame: decodable alone
inline constexpr uint8_t kDelta = 2;      // needs the frames before it since the last key frame
inline constexpr uint8_t kKeepAlive = 3;  // no payload: nothing changed (sent every 2 s)
}  // namespace video_chunk

inline constexpr std::string_view kStreamBoundary = "myriad-frame";
// GET .../events: Server-Sent Events of the session's version.
inline constexpr std::string_view kEventStreamContentType = "text/event-stream";
inline constexpr std::string_view kStreamContentType = "multipart/x-mixed-replace; boundary=myriad-frame";
inline constexpr std::string_view kJsonContentType = "application/json";
inline constexpr std::string_view kProblemContentType = "application/problem+json";
inline constexpr std::string_view kUploadContentType = "application/octet-stream";
inline constexpr std::string_view kZipContentType = "application/zip";  // a model with its files
inline constexpr std::string_view kMultipartContentType = "multipart/form-data";  // several files
inline constexpr std::string_view kRadianceContentType = "image/vnd.radiance";  // an .hdr
inline constexpr std::string_view kRawContentType = "application/octet-stream";
inline constexpr std::string_view kPngContentType = "image/png";
inline constexpr std::string_view kJpegContentType = "image/jpeg";
inline constexpr std::string_view kNpyContentType = "application/x-npy";
inline constexpr std::string_view kExrContentType = "image/x-exr";
// GET /metrics: the Prometheus text exposition format, version 0.0.4.
inline constexpr std::string_view kMetricsContentType = "text/plain; version=0.0.4; charset=utf-8";
inline constexpr std::string_view kBuiltinModel = "builtin:default";
inline constexpr std::string_view kLibraryPrefix = "library:";
inline constexpr std::string_view kUploadPrefix = "upload:";
inline constexpr size_t kMaxLightsPerAdd = 100000;  // POST .../lights, per request
inline constexpr size_t kTokenBytes = 32;           // 64 hex digits
// Lighting techniques: settings' "technique", GET /v1/info "techniques". The list and its order are
// the renderer's too: render::Technique is an index into kTechniques, and
// server/render/techniques/registry.cpp has one entry per name, in this order (checked when it
// compiles). defs.schema.json's "technique" enum mirrors it (tests/protocol_tests.cpp).
namespace techniques {
inline constexpr std::string_view kVolumes = "volumes";      // rasterised light volumes
inline constexpr std::string_view kTiled = "tiled";          // compute, per-tile lists
inline constexpr std::string_view kClustered = "clustered";  // compute, per-cluster lists
}  // namespace techniques
inline constexpr std::array kTechniques = {techniques::kVolumes, techniques::kTiled,
                                           techniques::kClustered};
// A local light's "type" and "attenuation" (light*.schema.json, defs.schema.json lightType and
// attenuation).
namespace light_types {
inline constexpr std::string_view kPoint = "point";  // every direction
inline constexpr std::string_view kSpot = "spot";    // a cone (glTF KHR_lights_punctual's spot)
}  // namespace light_types
namespace attenuations {
inline constexpr std::string_view kWindow = "window";                 // (r^2 - d^2) / (C d^2 + r^2)
inline constexpr std::string_view kInverseSquare = "inverse-square";  // glTF's 1/d^2, windowed
}  // namespace attenuations
// The environment light's modes (settings "environment.mode"): render::EnvironmentMode is an
// index into kEnvironmentModes; the settings schemas' enum mirrors it (tests/protocol_tests.cpp).
namespace environment_modes {
inline constexpr std::string_view kNone = "none";  // the constant ambient term
inline constexpr std::string_view kSky = "sky";    // the procedural sky, following the sun
inline constexpr std::string_view kHdr = "hdr";    // the session's equirectangular .hdr
}  // namespace environment_modes
inline constexpr std::array kEnvironmentModes = {environment_modes::kNone, environment_modes::kSky,
                                                 environment_modes::kHdr};
// Anti-aliasing of the final image (settings "antialias", ?antialias=): render::Antialias is an
// index into kAntialiasModes; the schemas' enum mirrors it (tests/protocol_tests.cpp).
namespace antialias_modes {
inline constexpr std::string_view kNone = environment_modes::kNone;  // the image as tonemapped
inline constexpr std::string_view kFxaa = "fxaa";  // a luminance-edge post-process (compute)
inline constexpr std::string_view kTaa = "taa";    // 8 jittered sub-frames, clamped and blended
inline constexpr std::string_view kSsaa = "ssaa";  // rendered at 2x2 the size, box-downsampled
}  // namespace antialias_modes
inline constexpr std::array kAntialiasModes = {antialias_modes::kNone, antialias_modes::kFxaa,
                                               antialias_modes::kTaa, antialias_modes::kSsaa};
// How local lights cast shadows (settings "shadows.local"): render::LocalShadows is an index
// into kLocalShadowModes; defs.schema.json's localShadows enum mirrors it.
namespace local_shadow_modes {
inline constexpr std::string_view kNone = environment_modes::kNone;  // local lights unshadowed
inline constexpr std::string_view kMaps = "maps";  // the budgeted shadow maps (maxShadowedLights)
inline constexpr std::string_view kStochastic = "stochastic";  // every light: sampled, ray traced
}  // namespace local_shadow_modes
inline constexpr std::array kLocalShadowModes = {local_shadow_modes::kNone, local_shadow_modes::kMaps,
                                                 local_shadow_modes::kStochastic};
// What a frame shows: ?target=, GET /v1/info "targets", X-Myriad-Target. In render::Target's order
// (which the shaders' MYRIAD_VIEW_* values follow): the final image, then G-buffer and debug views.
inline constexpr std::array<std::string_view, 18> kTargets = {
    "final",     "albedo",      "normal",        "position",   "uv",          "metallic",
    "roughness", "depth",       "light-volumes", "light-count", "clusters",   "emissive",
    "occlusion", "instance-id", "semantic-id",   "material-id", "motion",     "shadow"};
// Frame formats: png16 (16-bit grey: depth and the ids), npy (NumPy), exr (OpenEXR), npz
// (several targets, NumPy's zip of .npy files); reference.md "Frame formats".
inline constexpr std::array<std::string_view, 7> kFormats = {"png", "jpeg", "raw", "png16",
                                                             "npy", "exr", "npz"};
// A material's texture slots (GET .../materials/{mid} "textures"[].slot), in the order of
// scene::Material::texture and of the shaders' MYRIAD_BINDING_TEXTURE_* bindings.
inline constexpr std::array<std::string_view, 5> kTextureSlots = {
    "baseColor", "metallicRoughness", "normal", "occlusion", "emissive"};  // names-once: slots, not targets
// A material's alphaMode (glTF's OPAQUE, MASK, BLEND), in scene::AlphaMode order.
inline constexpr std::array<std::string_view, 3> kAlphaModes = {"opaque", "mask", "blend"};
// A texture's sampler, in scene::Sampler's enum orders.
inline constexpr std::array<std::string_view, 3> kWrapModes = {"repeat", "clamp-to-edge",
                                                               "mirrored-repeat"};
inline constexpr std::array<std::string_view, 2> kFilters = {"linear", "nearest"};

}  // namespace myriad::protocol
