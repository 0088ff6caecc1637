#include "protocol/operations.h"

#include <string>

#include "protocol/constants.h"

namespace myriad::protocol {
namespace {

using nlohmann::json;
namespace n = schema_names;

// A component schema of the OpenAPI document (openapi.cpp adds "target" and "format" beside the
// schemas of protocol/schemas).
json component(std::string_view name) {
  return {{"$ref", "#/components/schemas/" + std::string(name)}};
}

json integerFrom(uint64_t minimum) {
  return {{"type", "integer"}, {"minimum", minimum}};
}

json integerIn(uint64_t minimum, uint64_t maximum) {
  return {{"type", "integer"}, {"minimum", minimum}, {"maximum", maximum}};
}

// Query parameters several routes share.
QueryParameter target() {
  return {"target", component("target"),
          "What to render: final (tonemapped, sRGB) or a G-buffer or debug view; GET /v1/info "
          "lists them. Default final."};
}
QueryParameter width() {
  return {"width", integerFrom(1),
          "Image width in pixels, at most limits.maxResolution. Default 1280 (shrunk to fit)."};
}
QueryParameter height() {
  return {"height", integerFrom(1),
          "Image height in pixels, at most limits.maxResolution. Default 720 (shrunk to fit)."};
}
QueryParameter frameFormat() {
  return {"format", component("format"),
          "png (8-bit), jpeg, or raw (little-endian float32, see the X-Myriad-* headers); session "
          "frames also png16 (16-bit grey: depth, ids), npy, exr and npz (reference.md \"Frame "
          "formats\"). Default png."};
}
QueryParameter compression() {
  return {query::kCompression,
          {{"type", "string"},
           {"enum", {query::kPngCompressions[0], query::kPngCompressions[1],
                     query::kPngCompressions[2]}}},
          "PNG compression: none (stored), fast or small; every choice decodes to the same "
          "pixels. Default fast."};
}
QueryParameter quality() {
  return {"quality", integerIn(query::kMinQuality, query::kMaxQuality),
          "JPEG quality; accepted and checked for every format. Default 85."};
}

// What a frame answers, and the headers that describe it.
Response frameResponse() {
  return {200,
          "The frame. raw: width x height x N little-endian float32 values, rows top first, "
          "channels interleaved as X-Myriad-Channels names them; npy, npz (a zip of .npy files "
          "with K and world_from_camera) and exr (OpenEXR, the targets as layers): reference.md "
          "\"Frame formats\".",
          {{kPngContentType, ""}, {kJpegContentType, ""}, {kRawContentType, ""},
           {kNpyContentType, ""}, {kExrContentType, ""}, {kZipContentType, ""}},
          {headers::kServerTiming, headers::kTechnique, headers::kWidth, headers::kHeight,
           headers::kChannels, headers::kTarget, headers::kIntrinsics, headers::kPose,
           headers::kDepth, headers::kDtype, headers::kSpace, headers::kTargets,
           headers::kFrameTime, headers::kFrameVersion, headers::kDepthScale}};
}

Response json200(std::string_view schema, std::string_view description) {
  return {200, description, {{kJsonContentType, schema}}, {}};
}

Response noContent(std::string_view description) {
  return {204, description, {}, {}};
}

// Statuses of every session route: a bad query (unknown parameter), no or a malformed token, the
// token of another session, an unknown or closed session.
const std::vector<int> kSessionProblems = {400, 401, 403, 404};
// ... and those with a JSON body: its schema, its size, its media type.
const std::vector<int> kSessionBodyProblems = {400, 401, 403, 404, 413, 415};

std::vector<Operation> buildOperations() {
  std::vector<Operation> ops;

  // Server-wide routes.
  ops.push_back({.method = "GET",
                 .route = routes::kHealth,
                 .id = "getHealth",
                 .tag = "Server",
                 .summary = "Liveness",
                 .responses = {json200(n::kHealth, "The server accepts requests.")}});
  ops.push_back({.method = "GET",
                 .route = routes::kReady,
                 .id = "getReady",
                 .tag = "Server",
                 .summary = "Readiness: whether the server takes new sessions",
                 .responses = {json200(n::kHealth,
                                       "The server takes new sessions (below --max-sessions, "
                                       "not shutting down).")},
                 .problems = {503}});
  ops.push_back({.method = "GET",
                 .route = routes::kInfo,
                 .id = "getInfo",
                 .tag = "Server",
                 .summary = "The device, limits, targets, techniques and formats",
                 .responses = {json200(n::kInfo, "What the server runs on and what it serves.")}});
  ops.push_back(
      {.method = "GET",
       .route = routes::kOpenApi,
       .id = "getOpenApi",
       .tag = "Server",
       .summary = "This API as an OpenAPI 3.1 document",
       .responses = {{200, "The OpenAPI 3.1 document (this one).", {{kJsonContentType, ""}}, {}}}});
  ops.push_back(
      {.method = "GET",
       .route = routes::kFrame,
       .id = "getFrame",
       .tag = "Frames",
       .summary = "One frame of the built-in scene, without a session",
       .query = {target(),
                 width(),
                 height(),
                 frameFormat(),
                 quality(),
                 compression(),
                 {"eye",
                  {{"type", "string"}},
                  "Camera position x,y,z: three finite numbers, each within +-1e6. Default: the "
                  "scene's camera."},
                 {"look_at",
                  {{"type", "string"}},
                  "The point looked at, x,y,z, different from eye. Default: the scene's camera."},
                 {"fov",
                  {{"type", "number"}, {"exclusiveMinimum", 0}, {"exclusiveMaximum", 180}},
                  "Vertical field of view in degrees. Default: the scene's camera."},
                 {"markers",
                  {{"type", "boolean"}},
                  "Draw a small marker at each local light (true, false, 1 or 0). Default true."},
                 {"exposure",
                  {{"type", "number"}, {"exclusiveMinimum", 0}},
                  "Multiplier before tonemapping. Default 1."},
                 {"technique", component("technique"),
                  "How local lights are shaded. Default: GET /v1/info defaultTechnique."},
                 {"antialias", component("antialias"),
                  "Anti-aliasing of the final image (none, fxaa, taa or ssaa; data views and raw "
                  "output are never filtered, jittered or supersampled). Default fxaa."}},
       .responses = {frameResponse()},
       .problems = {400, 500, 503}});
  ops.push_back({.method = "GET",
                 .route = routes::kModels,
                 .id = "listModels",
                 .tag = "Server",
                 .summary = "The model files of the --models directory",
                 .responses = {json200(n::kModelsList,
                                       "Every model file, by its name relative to the directory.")},
                 .problems = {400}});
  ops.push_back(
      {.method = "GET",
       .route = routes::kMetrics,
       .id = "getMetrics",
       .tag = "Server",
       .summary = "Prometheus metrics",
       .responses =
           {{200, "Prometheus text exposition format 0.0.4.", {{kMetricsContentType, ""}}, {}}},
       .problems = {400}});
  ops.push_back({.method = "GET",
                 .route = routes::kWebRoot,
                 .id = "getWebClient",
                 .tag = "Web client",
                 .summary = "The web client's page",
                 .anyQuery = true,
                 .responses = {{200, "The page (HTML).", {{"text/html", ""}}, {}}}});
  ops.push_back({.method = "GET",
                 .route = routes::kWebFile,
                 .id = "getWebClientFile",
                 .tag = "Web client",
                 .summary = "A file of the web client (scripts, styles)",
                 .anyQuery = true,
                 .responses = {{200, "The file, with its media type.", {{"*/*", ""}}, {}}},
                 .problems = {404}});

  // Sessions.
  ops.push_back({.method = "POST",
                 .route = routes::kSessions,
                 .id = "createSession",
                 .tag = "Sessions",
                 .summary = "Open a session",
                 .access = Access::ApiKeyWhenSet,
                 .body = {{kJsonContentType, n::kSessionCreate}},
                 .bodyRequired = false,
                 .responses = {{201,
                                "The session: its id, its token, and its state.",
                                {{kJsonContentType, n::kSessionCreated}},
                                {headers::kLocation}}},
                 .problems = {400, 401, 404, 413, 415, 422, 429, 503}});
  ops.push_back({.method = "GET",
                 .route = routes::kSession,
                 .id = "getSession",
                 .tag = "Sessions",
                 .summary = "A session's state",
                 .access = Access::Session,
                 .responses = {json200(n::kSessionState, "The session state.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSession,
                 .id = "deleteSession",
                 .tag = "Sessions",
                 .summary = "Delete a session (its GPU memory is freed before the answer)",
                 .access = Access::Session,
                 .responses = {noContent("Deleted; its streams end.")},
                 .problems = kSessionProblems});

  ops.push_back({.method = "GET",
                 .route = routes::kSessionSnapshot,
                 .id = "getSnapshot",
                 .tag = "Sessions",
                 .summary = "The session's whole state but the model's bytes, as one document",
                 .access = Access::Session,
                 .responses = {json200(n::kSnapshot, "The snapshot.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PUT",
                 .route = routes::kSessionSnapshot,
                 .id = "putSnapshot",
                 .tag = "Sessions",
                 .summary = "Restore a snapshot's camera, settings, materials and lights into "
                            "the session (its model stays)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kSnapshot}},
                 .responses = {json200(n::kSessionState, "The session state.")},
                 .problems = {400, 401, 403, 404, 413, 415, 429}});

  ops.push_back({.method = "POST",
                 .route = routes::kSessionTokens,
                 .id = "createToken",
                 .tag = "Sessions",
                 .summary = "Make a viewer token: it reads and watches the session (every GET) "
                            "but cannot change it (403); owner's token only",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kTokenCreate}},
                 .responses = {{201,
                                "The token (shown once: the server keeps its SHA-256), its "
                                "role, its lifetime and the web client's link with it.",
                                {{kJsonContentType, n::kTokenCreated}},
                                {}}},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSessionTokens,
                 .id = "revokeTokens",
                 .tag = "Sessions",
                 .summary = "Revoke every viewer token of the session (owner's token only)",
                 .access = Access::Session,
                 .responses = {noContent("Revoked; viewers' next requests are 401.")},
                 .problems = kSessionProblems});

  // Model.
  ops.push_back(
      {.method = "PUT",
       .route = routes::kSessionModel,
       .id = "putSessionModel",
       .tag = "Model",
       .summary =
           "Replace the session's model: a library model, the built-in one, or an uploaded file",
       .access = Access::Session,
       .query =
           {{"filename",
             {{"type", "string"}, {"minLength", 1}, {"maxLength", 255}, {"pattern", "^[^/]+$"}},
             "An upload's file name, NAME.EXT: the extension names the format. Required "
             "with application/octet-stream, refused with JSON."},
            {"lights",
             {{"type", "string"}, {"enum", {"keep", "model", "fit"}}},
             "keep the session's lights as they are, replace them with the model's glTF "
             "punctual lights (model), or generate them again around the new model (fit: the "
             "same count and seed). Without it: fit while the lights are still generated with "
             "the defaults (the built-in scene's, lights/generate without bounds, radius, "
             "intensity or falloff), keep once any light was edited."},
            {"entry",
             {{"type", "string"}, {"minLength", 1}, {"maxLength", 4096}},
             "The model file inside a zip or multipart upload of several files (its path "
             "there); without it, the upload's one model file. Refused with other forms."}},
       .body = {{kJsonContentType, n::kModelSource},
                {kUploadContentType, ""},
                {kZipContentType, ""},
                {kMultipartContentType, ""}},
       .responses = {json200(n::kSessionState, "The new session state.")},
       .problems = {400, 401, 403, 404, 413, 415, 422, 503}});

  // Camera.
  ops.push_back({.method = "GET",
                 .route = routes::kSessionCamera,
                 .id = "getCamera",
                 .tag = "Camera",
                 .summary = "The camera",
                 .access = Access::Session,
                 .responses = {json200(n::kCamera, "The camera.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PUT",
                 .route = routes::kSessionCamera,
                 .id = "putCamera",
                 .tag = "Camera",
                 .summary = "Set the whole camera",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kCamera}},
                 .responses = {json200(n::kCamera, "The camera.")},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionCamera,
                 .id = "patchCamera",
                 .tag = "Camera",
                 .summary = "Change some members of the camera",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kCameraPatch}},
                 .responses = {json200(n::kCamera, "The whole camera.")},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionCameraFrame,
                 .id = "frameCamera",
                 .tag = "Camera",
                 .summary = "Move the camera so that the model fills the view",
                 .access = Access::Session,
                 .responses = {json200(n::kCamera, "The camera.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionCameraSelect,
                 .id = "selectModelCamera",
                 .tag = "Camera",
                 .summary = "Make one of the model file's cameras (model.cameras) the session's camera",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kCameraSelect}},
                 .responses = {json200(n::kCamera, "The camera.")},
                 .problems = kSessionBodyProblems});

  // Settings.
  ops.push_back({.method = "GET",
                 .route = routes::kSessionSettings,
                 .id = "getSettings",
                 .tag = "Settings",
                 .summary = "Sun, ambient, exposure, markers, anti-aliasing, technique, animation, background",
                 .access = Access::Session,
                 .responses = {json200(n::kSettings, "The settings.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionSettings,
                 .id = "patchSettings",
                 .tag = "Settings",
                 .summary = "Change some settings (the members of sun individually)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kSettingsPatch}},
                 .responses = {json200(n::kSettings, "The whole settings.")},
                 .problems = kSessionBodyProblems});

  ops.push_back(
      {.method = "PUT",
       .route = routes::kSessionEnvironment,
       .id = "putEnvironment",
       .tag = "Settings",
       .summary = "Give the session an equirectangular Radiance .hdr as its environment light "
                  "(selects environment mode hdr)",
       .access = Access::Session,
       .query = {{"filename",
                  {{"type", "string"}, {"minLength", 1}, {"maxLength", 255}, {"pattern", "^[^/]+$"}},
                  "An upload's file name, for messages (default upload.hdr). Refused with JSON."}},
       .body = {{kRadianceContentType, ""},
                {kUploadContentType, ""},
                {kJsonContentType, n::kModelSource}},
       .responses = {json200(n::kSettings, "The whole settings (environment mode hdr).")},
       .problems = {400, 401, 403, 404, 413, 415, 422, 503}});

  // Materials.
  ops.push_back({.method = "GET",
                 .route = routes::kSessionMaterials,
                 .id = "listMaterials",
                 .tag = "Materials",
                 .summary = "The model's materials, in id order",
                 .access = Access::Session,
                 .responses = {json200(n::kMaterialsList, "Every material.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionMaterial,
                 .id = "patchMaterial",
                 .tag = "Materials",
                 .summary = "Change a material's base colour, metallic or roughness",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kMaterialPatch}},
                 .responses = {json200(n::kMaterial, "The material.")},
                 .problems = kSessionBodyProblems});

  // Lights.
  ops.push_back({.method = "GET",
                 .route = routes::kSessionLights,
                 .id = "listLights",
                 .tag = "Lights",
                 .summary = "A page of lights, in id order",
                 .access = Access::Session,
                 .query = {{"offset", integerFrom(0), "Lights to skip. Default 0."},
                           {"limit", integerIn(0, query::kMaxLightsPageLimit),
                            "Most lights to return. Default " +
                                std::to_string(query::kDefaultLightsPageLimit) + "."}},
                 .responses = {json200(n::kLightsPage, "The page and the session's light count.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionLights,
                 .id = "addLights",
                 .tag = "Lights",
                 .summary = "Add lights (ids are assigned by the server)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kLightsAdd}},
                 .responses = {{201,
                                "The new ids in request order, and the light count now.",
                                {{kJsonContentType, n::kLightsAdded}},
                                {}}},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSessionLights,
                 .id = "clearLights",
                 .tag = "Lights",
                 .summary = "Remove every light",
                 .access = Access::Session,
                 .responses = {noContent("Every light removed.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionLightsGenerate,
                 .id = "generateLights",
                 .tag = "Lights",
                 .summary = "Random lights from a seed (the same request gives the same lights)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kLightsGenerate}},
                 .responses = {json200(n::kLightsGenerated, "The session's light count now.")},
                 .problems = kSessionBodyProblems});
  ops.push_back(
      {.method = "GET",
       .route = routes::kSessionLightsPick,
       .id = "pickLight",
       .tag = "Lights",
       .summary = "The light whose marker is under a pixel of a frame of the session's camera",
       .access = Access::Session,
       .query = {{"x", {{"type", "number"}, {"minimum", 0}},
                  "The pixel's column, 0 at the left, less than width (fractions allowed)."},
                 {"y", {{"type", "number"}, {"minimum", 0}},
                  "The pixel's row, 0 at the top, less than height."},
                 {"width", integerIn(1, 16384), "The frame's width in pixels (the view clicked)."},
                 {"height", integerIn(1, 16384), "The frame's height in pixels."},
                 {"radius", {{"type", "number"}, {"minimum", 0}, {"maximum", 64}},
                  "Also pick a marker whose edge is within this many pixels. Default 0."}},
       .responses = {json200(n::kLightPick,
                             "The light (absent when no marker is within reach) and how many "
                             "were.")},
       .problems = kSessionProblems});
  ops.push_back({.method = "GET",
                 .route = routes::kSessionLight,
                 .id = "getLight",
                 .tag = "Lights",
                 .summary = "One light",
                 .access = Access::Session,
                 .responses = {json200(n::kLight, "The light.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionLight,
                 .id = "patchLight",
                 .tag = "Lights",
                 .summary = "Change some members of a light",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kLightPatch}},
                 .responses = {json200(n::kLight, "The light.")},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSessionLight,
                 .id = "deleteLight",
                 .tag = "Lights",
                 .summary = "Remove one light",
                 .access = Access::Session,
                 .responses = {noContent("Removed.")},
                 .problems = kSessionProblems});

  // Assets and objects: the scene the session draws.
  const std::vector<QueryParameter> assetUploadQuery = {
      {"filename",
       {{"type", "string"}, {"minLength", 1}, {"maxLength", 255}, {"pattern", "^[^/]+$"}},
       "An upload's file name, NAME.EXT: the extension names the format. Required with "
       "application/octet-stream, refused with JSON."},
      {"entry",
       {{"type", "string"}, {"minLength", 1}, {"maxLength", 4096}},
       "The model file inside a zip or multipart upload of several files."}};
  ops.push_back({.method = "GET",
                 .route = routes::kSessionAssets,
                 .id = "listAssets",
                 .tag = "Scene",
                 .summary = "The session's assets, in the order they were added",
                 .access = Access::Session,
                 .responses = {json200(n::kAssetsList, "Every asset.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionAssets,
                 .id = "addAsset",
                 .tag = "Scene",
                 .summary = "Add an asset (a model file, a library model or the built-in scene) "
                            "without drawing it; the same bytes again are the same asset",
                 .access = Access::Session,
                 .query = assetUploadQuery,
                 .body = {{kJsonContentType, n::kModelSource},
                          {kUploadContentType, ""},
                          {kZipContentType, ""},
                          {kMultipartContentType, ""}},
                 .responses = {{201, "The new asset.", {{kJsonContentType, n::kAsset}}, {}},
                               json200(n::kAsset, "The session already had it (the same id).")},
                 .problems = {400, 401, 403, 404, 413, 415, 422, 503}});
  ops.push_back({.method = "GET",
                 .route = routes::kSessionAsset,
                 .id = "getAsset",
                 .tag = "Scene",
                 .summary = "One asset",
                 .access = Access::Session,
                 .responses = {json200(n::kAsset, "The asset.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSessionAsset,
                 .id = "deleteAsset",
                 .tag = "Scene",
                 .summary = "Remove an asset no object uses",
                 .access = Access::Session,
                 .responses = {noContent("Removed; later assets' material ids moved down.")},
                 .problems = {400, 401, 403, 404, 409}});
  ops.push_back({.method = "GET",
                 .route = routes::kSessionObjects,
                 .id = "listObjects",
                 .tag = "Scene",
                 .summary = "A page of objects, in id order",
                 .access = Access::Session,
                 .query = {{"offset", integerFrom(0), "Objects to skip. Default 0."},
                           {"limit", integerIn(0, query::kMaxObjectsPageLimit),
                            "Most objects to return. Default " +
                                std::to_string(query::kDefaultObjectsPageLimit) + "."}},
                 .responses = {json200(n::kObjectsPage, "The page and the session's object count.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = routes::kSessionObjects,
                 .id = "addObjects",
                 .tag = "Scene",
                 .summary = "Add objects: instances of assets (ids are assigned by the server)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kObjectsAdd}},
                 .responses = {{201,
                                "The new ids in request order, and the object count now.",
                                {{kJsonContentType, n::kObjectsAdded}},
                                {}}},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "GET",
                 .route = routes::kSessionObject,
                 .id = "getObject",
                 .tag = "Scene",
                 .summary = "One object",
                 .access = Access::Session,
                 .responses = {json200(n::kObject, "The object.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionObject,
                 .id = "patchObject",
                 .tag = "Scene",
                 .summary = "Change some members of an object (a transform alone moves only it "
                            "and its children)",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kObjectPatch}},
                 .responses = {json200(n::kObject, "The object.")},
                 .problems = kSessionBodyProblems});
  ops.push_back({.method = "DELETE",
                 .route = routes::kSessionObject,
                 .id = "deleteObject",
                 .tag = "Scene",
                 .summary = "Remove an object and its children",
                 .access = Access::Session,
                 .responses = {noContent("Removed.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "POST",
                 .route = "/v1/sessions/{id}/objects/{oid}/duplicate",
                 .id = "duplicateObject",
                 .tag = "Scene",
                 .summary = "Copy an object (and the objects below it) as new objects, with "
                            "another name, transform or parent if asked",
                 .access = Access::Session,
                 .body = {{kJsonContentType, "object-duplicate"}},
                 .bodyRequired = false,
                 .responses = {{201,
                                "The copies' ids, the copy of the object first, then the copies "
                                "of the objects below it (parents first); the object count now.",
                                {{kJsonContentType, n::kObjectsAdded}},
                                {}}},
                 .problems = kSessionBodyProblems});

  ops.push_back({.method = "GET",
                 .route = routes::kSessionClock,
                 .id = "getClock",
                 .tag = "Scene",
                 .summary = "The scene clock: the time the objects' animation clips play at",
                 .access = Access::Session,
                 .responses = {json200(n::kClock, "The clock now.")},
                 .problems = kSessionProblems});
  ops.push_back({.method = "PATCH",
                 .route = routes::kSessionClock,
                 .id = "patchClock",
                 .tag = "Scene",
                 .summary = "Play, pause, seek or change the rate of the scene clock",
                 .access = Access::Session,
                 .body = {{kJsonContentType, n::kClockPatch}},
                 .responses = {json200(n::kClock, "The clock after the change.")},
                 .problems = kSessionBodyProblems});

  ops.push_back({.method = "GET",
                 .route = routes::kSessionLabels,
                 .id = "getLabels",
                 .tag = "Scene",
                 .summary = "Per visible object of one frame: its pixels, 2D box, semantic class "
                            "and 3D box, with the frame's camera",
                 .access = Access::SessionOrQueryToken,
                 .query = {width(),
                           height(),
                           {"time",
                            {{"type", "number"}, {"minimum", 0}, {"maximum", 1e6}},
                            "Animation time in seconds. Default: the session's clock."}},
                 .responses = {json200(n::kLabels, "The frame's objects and camera.")},
                 .problems = {400, 401, 403, 404, 500, 503}});

  // Frames, streams, stats.
  ops.push_back(
      {.method = "GET",
       .route = routes::kSessionFrame,
       .id = "getSessionFrame",
       .tag = "Frames",
       .summary = "One frame of the session's scene, with its camera and settings",
       .access = Access::SessionOrQueryToken,
       .query = {{"target",
                  {{"type", "string"}},
                  "What to render: final or a G-buffer or debug view (GET /v1/info lists them); "
                  "with format npz or exr, a comma-separated list of up to " +
                      std::to_string(query::kMaxFrameTargets) +
                      " (maxFrameTargets), each once: one render, every target read back from "
                      "it. Default final."},
                 frameFormat(),
                 width(),
                 height(),
                 quality(),
                 compression(),
                 {query::kPrecision,
                  {{"type", "string"}, {"enum", {query::kExrPrecisions[0], query::kExrPrecisions[1]}}},
                  "EXR float channels: float (32-bit) or half. Default float."},
                 {"time",
                  {{"type", "number"}, {"minimum", 0}, {"maximum", 1e6}},
                  "Animation time in seconds: the objects' clips (the scene clock's time) and the "
                  "lights' animation. Default: the session's clocks."},
                 {"sample",
                  {{"type", "integer"}, {"minimum", 0}, {"maximum", 4294967295}},
                  "Which sample stochastic shadows (settings shadows.local stochastic) draw: the "
                  "same number the same picture, another an independent one, so the mean of "
                  "samples 0..N-1 of a still view converges to the exact shadows. Default 0."},
                 {query::kDepthConvention,
                  {{"type", "string"}, {"enum", {"z", "distance"}}},
                  "With target=depth and format=raw: z (metres along the view axis, the default) "
                  "or distance (metres to the camera centre)."},
                 {query::kSpace,
                  {{"type", "string"}, {"enum", {"world", "camera"}}},
                  "With target=position or normal and format=raw: world (the default) or camera "
                  "space (x right, y down, z forward: X-Myriad-Pose's axes)."},
                 {"eye",
                  {{"type", "string"}},
                  "A camera for this frame only (the session's stays as it is): its position "
                  "x,y,z, three finite numbers within +-1e6. Default: the session camera's."},
                 {"look_at",
                  {{"type", "string"}},
                  "This frame's point looked at, x,y,z, different from the eye. Default: the "
                  "session camera's target."},
                 {"up",
                  {{"type", "string"}},
                  "This frame's up direction x,y,z (not the zero vector). Default: the session "
                  "camera's."},
                 {"fov",
                  {{"type", "number"}, {"exclusiveMinimum", 0}, {"exclusiveMaximum", 180}},
                  "This frame's vertical field of view in degrees. Default: the session camera's."},
                 {"near",
                  {{"type", "number"}, {"exclusiveMinimum", 0}, {"maximum", 1e6}},
                  "This frame's near plane in metres, below far. Default: the session camera's."},
                 {"far",
                  {{"type", "number"}, {"exclusiveMinimum", 0}, {"maximum", 1e6}},
                  "This frame's far plane in metres, above near. Default: the session camera's."}},
       .responses = {frameResponse()},
       .problems = {400, 401, 403, 404, 500, 503}});
  ops.push_back(
      {.method = "GET",
       .route = routes::kSessionStream,
       .id = "getSessionStream",
       .tag = "Streams",
       .summary = "A live view: a new image whenever the scene changes, at most fps a second",
       .access = Access::SessionOrQueryToken,
       .query = {target(),
                 {"format",
                  {{"type", "string"}, {"enum", {"jpeg", "png"}}},
                  "jpeg or png. Default jpeg."},
                 {"fps", integerIn(query::kMinFps, query::kMaxFps),
                  "Most frames per second. Default " + std::to_string(query::kDefaultFps) + "."},
                 width(),
                 height(),
                 quality(),
                 {"codec",
                  {{"type", "string"},
                   {"enum", {kVideoCodecs[0], kVideoCodecs[1], kVideoCodecs[2]}}},
                  "A video stream in this codec instead of images (format and quality are then "
                  "refused; h264: even width and height). Default: images."},
                 {"container",
                  {{"type", "string"},
                   {"enum", {kVideoContainers[0], kVideoContainers[1], kVideoContainers[2]}}},
                  "Video streams: how the frames are framed. myriad: Myriad's own chunks "
                  "(vp8, vp9); webm: live WebM (vp8, vp9), video/webm; mp4: fragmented MP4 "
                  "(h264), video/mp4. webm and mp4 play in any player (ffmpeg, VLC, a video "
                  "element through Media Source Extensions). Default myriad for vp8 and vp9, mp4 "
                  "for h264; any other pair is refused."},
                 {"bitrate", integerIn(query::kMinBitrateKbps, query::kMaxBitrateKbps),
                  "Video streams: the target bitrate in kbit/s. Default 0.1 bit per pixel per "
                  "frame at the stream's size and fps."},
                 {"interactive", integerIn(0, query::kMaxInteractiveFps),
                  "Image streams: the frames a second to hold while the scene changes. Frames "
                  "rendered then are smaller (a render scale chosen from the server's frame "
                  "times), without anti-aliasing and sun shadows, at JPEG quality 50 at most, "
                  "and marked X-Myriad-Interactive; a full-quality still follows once the scene "
                  "stops changing. Default 0: every frame at full quality."}},
       .responses = {{200,
                      "multipart/x-mixed-replace: each part an image with Content-Type, "
                      "Content-Length and X-Myriad-Frame (its sequence number; a re-send keeps "
                      "it), and X-Myriad-Interactive (its render scale) when it is an interactive "
                      "frame. With codec: application/x-myriad-video, chunks of a 48-byte header "
                      "and one frame of the codec's bitstream; with container=webm, video/webm "
                      "(live WebM); with container=mp4, video/mp4 (fragmented MP4). "
                      "X-Myriad-Codec names the WebCodecs (and Media Source Extensions) codec "
                      "string.",
                      {{kStreamContentType, ""},
                       {kVideoStreamContentType, ""},
                       {kWebmContentType, ""},
                       {kMp4ContentType, ""}},
                      {headers::kVideoCodec}}},
       .problems = {400, 401, 403, 404, 429, 503}});
  ops.push_back(
      {.method = "GET",
       .route = routes::kSessionEvents,
       .id = "getSessionEvents",
       .tag = "Streams",
       .summary = "Server-Sent Events: the session's version now and whenever it changes",
       .access = Access::SessionOrQueryToken,
       .responses = {{200,
                      "text/event-stream: `event: version` with data {\"version\": N, \"role\": "
                      "\"owner\" or \"viewer\"} (the token's) on open "
                      "and on every change of the session, a `: keep-alive` comment every 15 s, "
                      "and a last `event: end` with data {\"reason\": \"deleted\", \"expired\" "
                      "or \"revoked\"} when the session closes or the viewer token is revoked or "
                      "expires. Takes no stream slot; at most 16 per session "
                      "(maxEventStreamsPerSession).",
                      {{kEventStreamContentType, ""}},
                      {}}},
       .problems = {401, 403, 404, 429, 503}});
  ops.push_back({.method = "GET",
                 .route = routes::kSessionStats,
                 .id = "getSessionStats",
                 .tag = "Stats",
                 .summary = "The last frame's GPU times, light culling and memory",
                 .access = Access::Session,
                 .responses = {json200(n::kStats, "The session's stats.")},
                 .problems = kSessionProblems});
  return ops;
}

}  // namespace

const std::vector<Operation>& operations() {
  static const std::vector<Operation> table = buildOperations();
  return table;
}

const Operation* findOperation(std::string_view method, std::string_view route) {
  for (const Operation& op : operations()) {
    if (op.method == method && op.route == route) return &op;
  }
  return nullptr;
}

std::vector<std::string_view> queryParameterNames(const Operation& operation) {
  std::vector<std::string_view> names;
  for (const QueryParameter& p : operation.query) names.push_back(p.name);
  if (operation.access == Access::SessionOrQueryToken) names.push_back(query::kToken);
  return names;
}

}  // namespace myriad::protocol
