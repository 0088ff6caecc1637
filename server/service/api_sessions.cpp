// POST /v1/sessions, GET/DELETE /v1/sessions/{id}, PUT /v1/sessions/{id}/model, GET /v1/models.
#include <algorithm>
#include <memory>

#include "loader/archive.h"
#include "loader/library.h"
#include "loader/loader.h"
#include "protocol/constants.h"
#include "protocol/types.h"
#include "protocol/validate.h"
#include "scene/builtin_scene.h"
#include "service/api.h"
#include "render/render_queue.h"
#include "service/session_json.h"

namespace myriad::service {
namespace {

// How a failed load is answered. The file's own faults are 422; the loader being saturated
// (`busy`: every child slot taken for the whole wall limit) is the server's state, so 503 with
// Retry-After, and a failure of the loader machinery itself (`internal`) is a 500.
Problem loadProblem(const loader::ModelRejected& e) {
  if (e.reason == "busy") {
    Problem p = serverBusy(std::string(e.what()) + " Retry in a few seconds.");
    p.retryAfterSeconds = 5;
    return p;
  }
  if (e.reason == "internal") return internalError(e.what());
  return modelRejected(std::string(e.what()) + " (" + e.reason + ")");
}


using ScenePtr = std::shared_ptr<scene::Scene>;

// Runs one loader call; a refusal becomes the problem it answers as (loadProblem).
template <typename Load>
ScenePtr loadOrProblem(Load load) {
  try {
    return std::make_shared<scene::Scene>(load());
  } catch (const loader::ModelRejected& e) {
    throw ProblemError(loadProblem(e));
  }
}

// The scene a "builtin:default" or "library:NAME" source names. Throws ProblemError 404 for a
// name outside the library, 422 when the loader rejects the file.
ScenePtr loadSource(const ApiContext& context, std::string_view source) {
  if (source == protocol::kBuiltinModel) {
    return std::make_shared<scene::Scene>(
        scene::makeBuiltinScene(context.config.builtinLights, context.config.builtinSeed));
  }
  // The schema admits only builtin:default and library:NAME.
  std::string_view name = source.substr(protocol::kLibraryPrefix.size());
  std::optional<std::filesystem::path> path;
  if (context.models != nullptr) path = context.models->resolve(name);
  if (!path) {
    throw ProblemError(notFoundDetail(
        "There is no model " + quoteClientText(name) +
        " in the server's library (GET /v1/models lists them" +
        (context.models == nullptr ? std::string("; this server has no --models directory).")
                                   : std::string(")."))));
  }
  return loadOrProblem([&] { return loader::loadModelFile(*path); });
}

// ?filename= of an upload: a file name without slashes. Throws 400 naming it.
std::string uploadFilename(const httplib::Request& req) {
  const std::string filename = req.get_param_value("filename");
  if (filename.size() > 255 || filename.find('/') != std::string::npos ||
      filename.find('\\') != std::string::npos) {
    throw ProblemError(invalidParameter(
        "filename", "\"filename\" must be a file name of at most 255 bytes without slashes."));
  }
  return filename;
}

// A model with the files it refers to, as a zip archive (application/zip, ?filename= optional,
// ?entry= the model inside when there are several). Read in the loader child.
ScenePtr loadArchiveUpload(const httplib::Request& req, std::string& source) {
  const std::string filename = req.has_param("filename") ? uploadFilename(req) : "upload.zip";
  source = std::string(protocol::kUploadPrefix) + filename;
  return loadOrProblem(
      [&] { return loader::loadModelArchive(req.body, filename, req.get_param_value("entry")); });
}

// Several files as multipart/form-data, each part a file (its filename the path the model uses
// for it, folders allowed); ?entry= names the model when there are several.
ScenePtr loadFilesUpload(const httplib::Request& req, std::string& source,
                         scene::MemoryFiles& files) {
  for (const auto& [field, part] : req.files) {
    if (part.filename.empty()) {
      throw ProblemError(invalidBody(
          "", "Every part of a multipart model upload must be a file (with a filename); the part " +
                  quoteClientText(field) + " has none."));
    }
    const std::optional<std::string> path = scene::normalizeMemberPath(part.filename);
    if (!path) {
      throw ProblemError(modelRejected("The uploaded file name " + quoteClientText(part.filename) +
                                       " is an absolute path or leaves the upload (..)."));
    }
    if (!files.emplace(*path, part.content).second) {
      throw ProblemError(
          modelRejected("The upload holds the file " + quoteClientText(*path) + " twice."));
    }
  }
  if (files.empty()) {
    throw ProblemError(invalidBody("", "A multipart model upload needs at least one file part."));
  }
  const std::string entry = req.get_param_value("entry");
  ScenePtr scene = loadOrProblem([&] { return loader::loadModelFiles(files, entry); });
  source = std::string(protocol::kUploadPrefix) +
           (entry.empty() ? scene::modelEntryOf(files, {}, "upload") : entry);
  return scene;
}

// The uploaded file of PUT .../model (application/octet-stream).
ScenePtr loadUpload(const httplib::Request& req) {
  if (!req.has_param("filename") || req.get_param_value("filename").empty()) {
    throw ProblemError(invalidParameter(
        "filename", "An upload needs ?filename=NAME.EXT: its extension tells the loader the "
                    "format (.glb, .gltf, .obj, ...)."));
  }
  const std::string filename = uploadFilename(req);
  return loadOrProblem([&] { return loader::loadModelBytes(req.body, filename); });
}

// Restores `snapshot` into the session (locked) and queues what the GPU scene needs.
// What a restore of `snapshot` loads without any lock: the library environment image it names
// (settings.environment.source "library:NAME" with mode hdr) unless it is `current`, and the
// builtin and library assets of its scene but those of ids in `have`.
SessionScene::SnapshotLoads snapshotEnvironment(const ApiContext& context,
                                                const protocol::Snapshot& snapshot,
                                                const std::string& current,
                                                const std::vector<std::string>& have = {}) {
  SessionScene::SnapshotLoads loads;
  const protocol::Environment& e = snapshot.settings.environment;
  if (e.mode == protocol::environment_modes::kHdr && e.source &&
      e.source->starts_with(protocol::kLibraryPrefix) && *e.source != current) {
    loads.image = loadLibraryEnvironment(context, *e.source);
    loads.source = *e.source;
  }
  if (snapshot.scene) {
    for (const protocol::SnapshotAsset& a : snapshot.scene->assets) {
      const std::string& id = a.id;
      const std::string& source = a.source;
      if (std::find(have.begin(), have.end(), id) != have.end() ||
          source.starts_with(protocol::kUploadPrefix) || id != assetIdOf(source)) {
        continue;  // the session's own, or one restore() names as missing
      }
      loads.assets.push_back(Asset{.id = id, .source = source, .scene = loadSource(context, source)});
    }
  }
  return loads;
}

std::vector<std::future<void>> queueRestore(ApiContext& context, Session& session,
                                            const protocol::Snapshot& snapshot,
                                            std::string_view pointer,
                                            const SessionScene::SnapshotLoads& image = {}) {
  SessionScene::Restored restored = session.scene.restore(snapshot, pointer, Clock::now(), image);
  std::vector<std::future<void>> done;
  if (restored.scene) done.push_back(context.renderThread.replaceScene(session.sceneId, std::move(restored.scene)));
  if (image.image) done.push_back(context.renderThread.setEnvironmentImage(session.sceneId, image.image));
  done.push_back(context.renderThread.updateLights(session.sceneId, std::move(restored.lights)));
  if (!restored.materials.empty()) {
    done.push_back(context.renderThread.updateMaterials(session.sceneId, std::move(restored.materials)));
  }
  return done;
}

void sendState(const ApiContext& context, httplib::Response& res, const Session& session,
               int status = 200) {
  sendJson(res, stateOf(session, context.sessions.expiresInSeconds(session)), status);
}

SessionScene newSessionScene(const ApiContext& context) {
  render::SceneSettings settings;
  settings.technique = context.config.defaultTechnique;
  // A session's scene (the built-in one or a model) is grounded by the sun's shadow from the
  // start; a client turns it off with PATCH .../settings {"shadows": {"sun": false}}.
  settings.shadows.sun = true;
  return SessionScene(context.config.limits.maxLightsPerSession, settings,
                      context.config.limits.maxObjectsPerSession);
}

// Gives a new session (its id not yet out, or being restored) its scene: adopts `loaded`, made
// from `source`, creates the GPU scene and, with a snapshot, restores the rest (problems point
// under `pointer`).
// `assetId` and `assetBytes`: the model's asset as Adoption has them (an upload's, by its bytes;
// empty: by the source's name).
void populate(ApiContext& context, Session& session, ScenePtr loaded, const std::string& source,
              const protocol::Snapshot* snapshot, std::string_view pointer,
              const SessionScene::SnapshotLoads& environment, const std::string& assetId = {},
              uint64_t assetBytes = 0) {
  std::shared_ptr<const scene::Scene> scene;
  {
    std::lock_guard lock(session.mutex);
    // The built-in scene's lights are generated: loading a model later fits them to it.
    std::optional<LightRecipe> recipe;
    if (source == protocol::kBuiltinModel) {
      recipe = LightRecipe{context.config.builtinLights, context.config.builtinSeed};
    }
    scene = session.scene.adopt(std::move(loaded), source,
                                Adoption{.lights = Adoption::Lights::model,
                                         .recipe = recipe,
                                         .lightingFromModel = true,
                                         .assetId = assetId,
                                         .assetBytes = assetBytes});
  }
  const render::SceneId sceneId = context.renderThread.createScene(scene).get();
  std::vector<std::future<void>> restored;
  {
    std::lock_guard lock(session.mutex);
    session.sceneId = sceneId;
    if (snapshot) restored = queueRestore(context, session, *snapshot, pointer, environment);
    session.lastUsed = Clock::now();
    session.bump();
  }
  for (std::future<void>& done : restored) done.get();
}

// The model a stored upload was made from, loaded again (in the loader child, as at upload).
// `size`: where to write how many bytes the upload has, when given.
ScenePtr loadStoredUpload(const ApiContext& context, const StoredUpload& upload,
                          uint64_t* size = nullptr) {
  std::string why;
  std::optional<std::string> bytes = context.state->blob(upload.blob, &why);
  if (!bytes) {
    throw ProblemError(modelRejected("The session's uploaded model " + upload.blob +
                                     " is unusable in the state directory: " + why + "."));
  }
  if (size != nullptr) *size = bytes->size();
  switch (upload.kind) {
    case StoredUpload::Kind::zip:
      return loadOrProblem(
          [&] { return loader::loadModelArchive(*bytes, upload.filename, upload.entry); });
    case StoredUpload::Kind::files: {
      // A blob that is no file set is the stored upload's fault: a 422 like a load's.
      scene::MemoryFiles files;
      try {
        files = loader::decodeFileSet(*bytes, "stored upload", {});
      } catch (const scene::ModelLoadError& e) {
        throw ProblemError(modelRejected(e.what()));
      }
      return loadOrProblem([&] { return loader::loadModelFiles(files, upload.entry); });
    }
    case StoredUpload::Kind::file:
      break;
  }
  return loadOrProblem([&] { return loader::loadModelBytes(*bytes, upload.filename); });
}

// A new session of `source`, restoring `snapshot` when given (problems point under `pointer`).
SessionPtr openSession(ApiContext& context, const std::string& source,
                       const protocol::Snapshot* snapshot, std::string_view pointer) {
  SessionPtr session = context.sessions.create(newSessionScene(context));
  try {
    // Loaded without the session's lock: a library model may take the loader's whole time limit,
    // and the idle sweeper takes every session's lock in turn.
    ScenePtr loaded = loadSource(context, source);
    const SessionScene::SnapshotLoads environment =
        snapshot ? snapshotEnvironment(context, *snapshot, "", {assetIdOf(source)})
                 : SessionScene::SnapshotLoads{};
    populate(context, *session, std::move(loaded), source, snapshot, pointer, environment);
  } catch (...) {
    context.sessions.remove(session->id);
    throw;
  }
  return session;
}

void createSession(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  const protocol::SessionCreate body =
      jsonBody(req, protocol::schema_names::kSessionCreate, "{}").get<protocol::SessionCreate>();
  const std::optional<protocol::Snapshot>& snapshot = body.snapshot;
  if (snapshot && body.model) {
    throw ProblemError(invalidBody(
        "/snapshot", "Give \"model\" or \"snapshot\", not both: a snapshot names its own model."));
  }
  if (snapshot && snapshot->model.source.starts_with(protocol::kUploadPrefix)) {
    throw ProblemError(invalidBody(
        "/snapshot/model/source",
        "The snapshot's model " + quoteClientText(snapshot->model.source) +
            " was uploaded, and a snapshot holds no model bytes: create a session, upload the "
            "model (PUT .../model), then PUT the snapshot to .../snapshot."));
  }
  const std::string source = snapshot ? snapshot->model.source
                                      : body.model.value_or(std::string(protocol::kBuiltinModel));

  SessionPtr session = openSession(context, source, snapshot ? &*snapshot : nullptr, "/snapshot");

  std::lock_guard lock(session->mutex);
  protocol::SessionCreated created;
  created.id = session->id;
  created.token = session->token;
  created.expiresInSeconds = uint64_t(context.sessions.expiresInSeconds(*session));
  created.session = stateOf(*session, int64_t(created.expiresInSeconds));
  res.set_header(std::string(protocol::headers::kLocation), protocol::expandRoute(protocol::routes::kSession, "id", session->id));
  sendJson(res, created, 201);
  std::fprintf(stderr, "myriad-server: session %s created (%s, %zu lights)\n", session->id.c_str(),
               source.c_str(), session->scene.lightCount());
}

}  // namespace

// The model a PUT .../model or POST .../assets request carries, loaded (see LoadedModel).
LoadedModel loadModelRequest(ApiContext& context, const httplib::Request& req) {
  // Loading takes from milliseconds to the loader's time limit; the session stays usable.
  const std::string type = req.get_header_value("Content-Type");
  ScenePtr scene;
  std::string source;
  // Windows browsers label a zip application/x-zip-compressed.
  const bool zip = type.starts_with(protocol::kZipContentType) ||
                   type.starts_with("application/x-zip-compressed");
  const bool multipart = type.starts_with(protocol::kMultipartContentType);
  const bool severalFiles = zip || multipart;
  scene::MemoryFiles uploadedFiles;  // a multipart upload's files
  if (req.has_param("entry") && !severalFiles) {
    throw ProblemError(invalidParameter(
        "entry", "\"entry\" names the model inside a zip or multipart upload of several files."));
  }
  if (multipart) {
    if (req.has_param("filename")) {
      throw ProblemError(invalidParameter(
          "filename", "A multipart upload names its files in its parts, not with ?filename=."));
    }
    scene = loadFilesUpload(req, source, uploadedFiles);
  } else if (zip) {
    scene = loadArchiveUpload(req, source);
  } else if (type.starts_with(protocol::kUploadContentType)) {
    scene = loadUpload(req);
    source = std::string(protocol::kUploadPrefix) + req.get_param_value("filename");
  } else if (type.starts_with(protocol::kJsonContentType)) {
    if (req.has_param("filename")) {
      throw ProblemError(invalidParameter(
          "filename", "\"filename\" goes with an application/octet-stream upload, not JSON."));
    }
    if (req.body.size() > context.config.limits.maxBodyBytes) {
      throw ProblemError(limitExceeded(
          413, "maxBodyBytes",
          "A JSON body may have at most " + std::to_string(context.config.limits.maxBodyBytes) +
              " bytes."));
    }
    source = jsonBody(req, protocol::schema_names::kModelSource)
                 .get<protocol::ModelSource>()
                 .source;
    scene = loadSource(context, source);
  } else {
    throw ProblemError(unsupportedMediaType(
        "PUT .../model takes application/json {\"source\": ...} or the file itself as "
        "application/octet-stream with ?filename=, a zip archive (application/zip) or several "
        "files (multipart/form-data), not " +
        quoteClientText(type.empty() ? std::string("no Content-Type") : type) + "."));
  }

  // With --state-dir, the bytes the model came from, so that a restore can load it again.
  std::optional<StoredUpload> stored;
  if (context.state != nullptr && source.starts_with(protocol::kUploadPrefix)) {
    stored.emplace();
    if (multipart) {
      stored->kind = StoredUpload::Kind::files;
      stored->entry = req.get_param_value("entry");
      stored->blob = context.state->putBlob(loader::encodeFileSet(uploadedFiles));
    } else {
      stored->kind = zip ? StoredUpload::Kind::zip : StoredUpload::Kind::file;
      stored->filename = zip ? (req.has_param("filename") ? uploadFilename(req) : "upload.zip")
                             : uploadFilename(req);
      stored->entry = req.get_param_value("entry");
      stored->blob = context.state->putBlob(req.body);
    }
  }

  LoadedModel out;
  // Content-addressed: an upload by its bytes (a multipart upload by its file set), a library or
  // built-in model by its name.
  if (source.starts_with(protocol::kUploadPrefix)) {
    const std::string content = multipart ? loader::encodeFileSet(uploadedFiles) : req.body;
    out.assetId = assetIdOf(content);
    out.bytes = content.size();
  } else {
    out.assetId = assetIdOf(source);
  }
  out.scene = std::move(scene);
  out.source = std::move(source);
  out.stored = std::move(stored);
  return out;
}

namespace {

void putModel(ApiContext& context, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  // Without ?lights=: generated lights are fitted to the new model, edited ones kept.
  Adoption::Lights lights = Adoption::Lights::automatic;
  if (req.has_param("lights")) {
    const std::string value = req.get_param_value("lights");
    if (value == "keep") {
      lights = Adoption::Lights::keep;
    } else if (value == "model") {
      lights = Adoption::Lights::model;
    } else if (value == "fit") {
      lights = Adoption::Lights::fit;
    } else {
      throw ProblemError(invalidParameter(
          "lights", "\"lights\" is keep (the session's lights as they are), model (the model's "
                    "own) or fit (generated again around the model); without it, generated "
                    "lights are fitted and edited ones kept."));
    }
  }

  LoadedModel model = loadModelRequest(context, req);
  std::future<void> replaced;
  {
    auto lock = lockOpen(*session);
    session->persisted.model = std::move(model.stored);
    std::shared_ptr<const scene::Scene> adopted = session->scene.adopt(
        std::move(model.scene), model.source,
        Adoption{.lights = lights, .assetId = model.assetId, .assetBytes = model.bytes});
    // Enqueued under the lock, so light edits after this one reach the new scene.
    replaced = context.renderThread.replaceScene(session->sceneId, std::move(adopted));
    session->bump();
  }
  replaced.get();
  std::lock_guard lock(session->mutex);
  sendState(context, res, *session);
}

// POST .../tokens: a viewer token, returned once and kept as its hash.
void createToken(ApiContext& /*context*/, const httplib::Request& req, httplib::Response& res) {
  SessionPtr session = requestSession();
  const auto body =
      jsonBody(req, protocol::schema_names::kTokenCreate).get<protocol::TokenCreate>();
  // The schema admits only the viewer role.
  const uint64_t ttl = body.ttlSeconds.value_or(protocol::kDefaultViewerTokenSeconds);
  protocol::TokenCreated created;
  created.token = randomToken();
  created.role = std::string(protocol::roles::kViewer);
  created.expiresInSeconds = ttl;
  created.link = std::string(protocol::routes::kWebRoot) + "#session=" + session->id +
                 "&token=" + created.token;
  {
    auto lock = lockOpen(*session);
    const int64_t now = unixNow();
    std::vector<ViewerToken>& tokens = session->viewerTokens;
    std::erase_if(tokens, [&](const ViewerToken& v) { return v.expiresAtUnix <= now; });
    if (tokens.size() >= protocol::kMaxViewerTokens) {
      // Bounded: the token that would expire first makes room.
      tokens.erase(std::min_element(tokens.begin(), tokens.end(), [](const auto& a, const auto& b) {
        return a.expiresAtUnix < b.expiresAtUnix;
      }));
    }
    tokens.push_back({sha256Hex(created.token), now + int64_t(ttl)});
    session->persisted.tokensChanged = true;
    // A token pushed out ends the streams opened with it (stream.h); nothing else changed.
    session->changed.notify_all();
  }
  sendJson(res, created, 201);
}

void revokeTokens(ApiContext& /*context*/, const httplib::Request& /*req*/, httplib::Response& res) {
  SessionPtr session = requestSession();
  {
    auto lock = lockOpen(*session);
    std::vector<std::string>& revoked = session->revokedViewerHashes;
    for (const ViewerToken& v : session->viewerTokens) revoked.push_back(v.hash);
    if (revoked.size() > protocol::kMaxViewerTokens) {
      revoked.erase(revoked.begin(), revoked.end() - protocol::kMaxViewerTokens);
    }
    session->viewerTokens.clear();
    session->persisted.tokensChanged = true;
    // Streams opened with these tokens wake and end at once, not at their next frame or re-send.
    // Not a bump(): the picture did not change.
    session->changed.notify_all();
  }
  res.status = 204;
}

}  // namespace

SessionPtr createSessionFromSnapshot(ApiContext& context, const protocol::Snapshot& snapshot) {
  if (snapshot.model.source.starts_with(protocol::kUploadPrefix)) {
    throw ProblemError(invalidBody("/snapshot/model/source",
                                   "The snapshot's model " + quoteClientText(snapshot.model.source) +
                                       " was uploaded; a snapshot holds no model bytes."));
  }
  return openSession(context, snapshot.model.source, &snapshot, "/snapshot");
}

namespace {

// The rest of restoreStoredSession(): `stored`, its snapshot checked, made a session again.
// Throws ProblemError; leaves no session behind when it does.
SessionPtr restoreSnapshot(ApiContext& context, const StoredSession& stored,
                           protocol::Snapshot snapshot, const std::string& ownerToken) {
  const std::string& source = snapshot.model.source;
  uint64_t modelBytes = 0;
  ScenePtr loaded = stored.model ? loadStoredUpload(context, *stored.model, &modelBytes)
                                 : loadSource(context, source);
  // The model's asset as the session had it (an upload by its bytes), so that the snapshot's
  // scene finds it.
  const std::string modelAsset = stored.model ? assetIdOfBlob(stored.model->blob) : std::string();
  // The snapshot scene's other uploaded assets, from the uploads the record keeps. A record
  // without one of them (written before assets were kept) restores as it did then: the model
  // as its one object.
  std::vector<Asset> uploaded;
  if (snapshot.scene) {
    for (const protocol::SnapshotAsset& a : snapshot.scene->assets) {
      if (!a.source.starts_with(protocol::kUploadPrefix) || a.id == modelAsset) continue;
      const auto upload = std::find_if(stored.assets.begin(), stored.assets.end(),
                                       [&](const StoredUpload& u) {
                                         return assetIdOfBlob(u.blob) == a.id;
                                       });
      if (upload == stored.assets.end()) {
        std::fprintf(stderr, "myriad-server: state: session %s: the bytes of asset %s are not "
                     "kept; restored with its model alone\n", stored.id.c_str(), a.id.c_str());
        snapshot.scene.reset();
        uploaded.clear();
        break;
      }
      uint64_t bytes = 0;
      ScenePtr scene = loadStoredUpload(context, *upload, &bytes);
      uploaded.push_back(Asset{.id = a.id, .source = a.source, .bytes = bytes, .scene = scene});
    }
  }
  SessionScene::SnapshotLoads environment;
  if (stored.environmentBlob) {
    std::string why;
    std::optional<std::string> bytes = context.state->blob(*stored.environmentBlob, &why);
    constexpr size_t kImageBytes =
        size_t(scene::kEnvironmentWidth) * scene::kEnvironmentHeight * 3 * sizeof(float);
    if (bytes && bytes->size() != kImageBytes) why = "it is not a decoded environment image";
    if (!why.empty()) {
      throw ProblemError(notFoundDetail("The session's environment image " +
                                        *stored.environmentBlob + " is unusable: " + why + "."));
    }
    auto image = std::make_shared<scene::EnvironmentImage>();
    image->rgb.resize(bytes->size() / sizeof(float));
    std::memcpy(image->rgb.data(), bytes->data(), bytes->size());
    // The snapshot's library assets (builtin, library:NAME) besides; not its environment again.
    const std::string current = snapshot.settings.environment.source.value_or("");
    environment = snapshotEnvironment(context, snapshot, current, {assetIdOf(source)});
    environment.image = std::move(image);
    environment.source = current;
  } else {
    environment = snapshotEnvironment(context, snapshot, "", {assetIdOf(source)});
  }
  for (Asset& a : uploaded) environment.assets.push_back(std::move(a));
  SessionPtr session = context.sessions.createWithIdentity(
      std::string(stored.id), ownerToken, stored.tokenHash, newSessionScene(context));
  try {
    populate(context, *session, std::move(loaded), source, &snapshot, "", environment, modelAsset,
             modelBytes);
  } catch (...) {
    context.sessions.remove(session->id);
    throw;
  }
  {
    std::lock_guard lock(session->mutex);
    session->persisted.model = stored.model;
    for (const StoredUpload& u : stored.assets) {
      session->persisted.assets.insert_or_assign(assetIdOfBlob(u.blob), u);
    }
    session->persisted.environmentBlob = stored.environmentBlob;
    // The ids the lights had: a client that added light 17 still finds it under 17.
    if (!stored.lightIds.empty() &&
        !session->scene.restoreLightIds(stored.lightIds, stored.nextLightId)) {
      std::fprintf(stderr, "myriad-server: state: session %s: stored light ids do not fit; "
                   "the lights have new ids\n", session->id.c_str());
    }
    // A write between populate() and here lacked these: the next one is complete.
    session->persisted.savedVersion = UINT64_MAX;
    // Served under the lease the restore took, going on from the stored version (a store refuses
    // a write that would go back).
    session->persisted.epoch = stored.epoch;
    session->persisted.storedVersion = int64_t(stored.version);
    session->version = std::max(session->version, stored.version);
    for (const StoredSession::Viewer& v : stored.viewers) {
      session->viewerTokens.push_back({v.tokenHash, v.expiresAtUnix});
    }
  }
  std::fprintf(stderr, "myriad-server: session %s restored from %s (%s)\n",
               session->id.c_str(), context.state->describe().c_str(), source.c_str());
  return session;
}

}  // namespace

SessionPtr restoreStoredSession(ApiContext& context, std::string_view id,
                                const std::string& token) {
  if (context.state == nullptr) return nullptr;
  std::optional<StoredSession> stored = context.state->load(id);
  if (!stored) return nullptr;
  const std::string hash = sha256Hex(token);
  const bool owner = constantTimeEquals(hash, stored->tokenHash);
  bool viewer = false;
  for (const StoredSession::Viewer& v : stored->viewers) {
    if (constantTimeEquals(hash, v.tokenHash)) viewer = true;
  }
  // An expired viewer token still restores the session; authorize() then answers 401 for it.
  if (!owner && !viewer) {
    throw ProblemError(forbidden("The token is not the token of the session " +
                                 quoteClientText(id) + "."));
  }
  // The stored snapshot is checked as a posted one is (jsonBody: the schema, then the types);
  // the rules across members run in populate(), as for POST /v1/sessions {"snapshot"}.
  protocol::Snapshot snapshot;
  try {
    if (auto error = protocol::validate(protocol::schema_names::kSnapshot, stored->snapshot)) {
      throw std::runtime_error("/snapshot" + error->pointer + ": " + error->message);
    }
    snapshot = stored->snapshot.get<protocol::Snapshot>();
  } catch (const std::exception& e) {
    context.state->refuse(id, e.what(), true);
    return nullptr;
  }
  try {
    return restoreSnapshot(context, *stored, std::move(snapshot), owner ? token : std::string());
  } catch (const ProblemError& e) {
    // What the file holds does not restore (a rule across members, more lights than this
    // server's limit, a model that no longer loads): the session is not found, as without the
    // file. The server's own state (a busy loader, no room for a session, a failure) is answered
    // as it is. A load may succeed later (the library or a blob mended): not remembered.
    const int status = e.problem().status;
    if (status == 429 || status >= 500) throw;
    const std::string pointer = e.problem().pointer.value_or("");
    context.state->refuse(id, pointer.empty() ? e.problem().detail
                                              : pointer + ": " + e.problem().detail,
                          status == 400 || status == 413);
    return nullptr;
  }
}

void addSessionRoutes(Routes& routes, ApiContext& context) {
  routes.add("POST", protocol::routes::kSessions, [&context](const httplib::Request& req,
                                               httplib::Response& res) {
    createSession(context, req, res);
  });
  routes.add("GET", protocol::routes::kSession,
             [&context](const httplib::Request& /*req*/, httplib::Response& res) {
               SessionPtr session = requestSession();
               auto lock = lockOpen(*session);
               sendState(context, res, *session);
             });
  routes.add("DELETE", protocol::routes::kSession,
             [&context](const httplib::Request& /*req*/, httplib::Response& res) {
               SessionPtr session = requestSession();
               // Deleting ends the session everywhere: its record goes too (expiry keeps it), if
               // this node still holds its lease.
               if (context.state != nullptr) {
                 uint64_t epoch = 0;
                 {
                   std::lock_guard lock(session->mutex);
                   epoch = session->persisted.epoch;
                 }
                 bool forgotten = false;
                 try {
                   forgotten = context.state->forget(session->id, context.stateNode, epoch);
                 } catch (const StoreUnavailable& e) {
                   Problem problem = serverBusy("The session could not be deleted from " +
                                                context.state->describe() + ": " + e.what());
                   problem.retryAfterSeconds = 1;
                   throw ProblemError(problem);
                 }
                 if (!forgotten) {
                   context.sessions.removeIf(session->id, session,
                                             Session::CloseReason::reloaded);
                   throw ProblemError(conflict("The session " + quoteClientText(session->id) +
                                               " is served by another node now; send the "
                                               "DELETE there."));
                 }
                 // Deleted in the store: the lease keeper may have closed the copy already.
                 context.sessions.remove(session->id);
                 res.status = 204;
                 return;
               }
               // Returns after the render thread has destroyed the GPU scene.
               if (!context.sessions.remove(session->id)) {
                 throw ProblemError(notFoundDetail("The session " + quoteClientText(session->id) +
                                                   " was already deleted."));
               }
               res.status = 204;
             });
  routes.add("POST", protocol::routes::kSessionTokens, bindContext(context, createToken));
  routes.add("DELETE", protocol::routes::kSessionTokens, bindContext(context, revokeTokens));
  RouteOptions upload;
  upload.maxBodyBytes = context.config.limits.maxUploadBytes;
  upload.bodyLimitName = "maxUploadBytes";
  routes.add("GET", protocol::routes::kSessionSnapshot,
             [&context](const httplib::Request& /*req*/, httplib::Response& res) {
               SessionPtr session = requestSession();
               auto lock = lockOpen(*session);
               sendJson(res, session->scene.snapshot());
             });
  // A snapshot may list many lights: the upload limit, not the JSON body limit, bounds it.
  routes.add(
      "PUT", protocol::routes::kSessionSnapshot,
      [&context](const httplib::Request& req, httplib::Response& res) {
        SessionPtr session = requestSession();
        const auto snapshot =
            jsonBody(req, protocol::schema_names::kSnapshot).get<protocol::Snapshot>();
        std::string current;
        std::vector<std::string> have;
        {
          auto lock = lockOpen(*session);
          if (session->scene.environmentImage()) current = session->scene.environmentSource();
          for (const Asset& a : session->scene.graph().assets()) have.push_back(a.id);
        }
        // Loaded without the lock (the loader may take seconds).
        const SessionScene::SnapshotLoads environment =
            snapshotEnvironment(context, snapshot, current, have);
        std::vector<std::future<void>> restored;
        {
          auto lock = lockOpen(*session);
          restored = queueRestore(context, *session, snapshot, "", environment);
          session->bump();
        }
        for (std::future<void>& done : restored) done.get();
        std::lock_guard lock(session->mutex);
        sendState(context, res, *session);
      },
      upload);
  routes.add(
      "PUT", protocol::routes::kSessionModel,
      [&context](const httplib::Request& req, httplib::Response& res) {
        putModel(context, req, res);
      },
      upload);
  routes.add("GET", protocol::routes::kModels, [&context](const httplib::Request& /*req*/,
                                            httplib::Response& res) {
    protocol::ModelsList list;
    if (context.models != nullptr) {
      for (const loader::LibraryEntry& entry : context.models->list()) {
        list.models.push_back(protocol::LibraryModel{entry.name, entry.bytes});
      }
    }
    sendJson(res, list);
  });
}

}  // namespace myriad::service
