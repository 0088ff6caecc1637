// load FILE [--entry PATH] | --library NAME | --builtin: PUT .../model; and sendModel, the upload
// that `asset add` shares.
#include <fstream>
#include <sstream>

#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

std::string readFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error("cannot read " + path);
  std::ostringstream bytes;
  bytes << file.rdbuf();
  if (file.bad()) throw std::runtime_error("cannot read " + path);
  return bytes.str();
}

std::string baseName(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// limits.maxUploadBytes from /v1/info, or 0 when it cannot be had.
uint64_t uploadLimit(Context& ctx) {
  try {
    nlohmann::json info = ctx.http.sendJson("GET", std::string(protocol::routes::kInfo));
    return info.at("limits").at(std::string(protocol::limits::kMaxUploadBytes)).get<uint64_t>();
  } catch (const std::exception&) {
    return 0;
  }
}

}  // namespace

HttpResponse sendModel(Context& ctx, const std::string& method, const std::string& route,
                       const ModelRequest& model, Query query) {
  if (!model.path) {
    protocol::ModelSource source;
    source.source = model.source;
    return ctx.http.sendOk(method, route, query, nlohmann::json(source).dump(),
                           std::string(protocol::kJsonContentType));
  }
  // The file itself; its extension tells the server's loader the format.
  const std::string& path = *model.path;
  std::string name = baseName(path);
  if (name.empty()) throw std::runtime_error(path + " is not a file");
  std::string bytes = readFile(path);
  query.insert(query.begin(), {"filename", name});
  // A .zip carries the model with the files it refers to; the server finds the model inside.
  const bool zip = name.ends_with(".zip");
  if (model.entry) query.emplace_back("entry", *model.entry);
  try {
    return ctx.http.sendOk(
        method, route, query, bytes,
        std::string(zip ? protocol::kZipContentType : protocol::kUploadContentType));
  } catch (const ApiError& e) {
    if (e.status() != 0) throw;
    // The server may close the connection before reading a body over its limit, so its 413
    // never arrives; say so when that is the likely reason.
    uint64_t limit = uploadLimit(ctx);
    if (limit != 0 && bytes.size() > limit) {
      throw ApiError(path + " has " + std::to_string(bytes.size()) +
                     " bytes, more than this server accepts (maxUploadBytes " +
                     std::to_string(limit) + ")");
    }
    throw;
  }
}

int runModelCommand(Context& ctx) {
  const Invocation& inv = ctx.inv;
  Query query;
  if (inv.has("model-lights")) query.emplace_back("lights", "model");

  ModelRequest model;
  if (!inv.positionals.empty()) {
    model.path = std::get<std::string>(inv.positionals[0]);
    model.entry = inv.find<std::string>("entry");
  } else {
    model.source = inv.has("builtin") ? std::string(protocol::kBuiltinModel)
                                      : std::string(protocol::kLibraryPrefix) +
                                            inv.get<std::string>("library");
  }
  const std::string raw =
      sendModel(ctx, "PUT", ctx.sessionRoute(protocol::routes::kSessionModel), model, query).body;
  if (ctx.json()) {
    printRaw(ctx.out, raw);
    return 0;
  }
  nlohmann::json parsed = nlohmann::json::parse(raw, nullptr, false);
  if (parsed.is_discarded()) throw ApiError("the server's answer to the model upload is not JSON");
  auto state = parsed.get<protocol::SessionState>();
  const protocol::ModelSummary& m = state.model;
  ctx.out << "loaded " << m.source << ": " << m.meshes << " meshes, " << m.instances
          << " instances, " << m.materials << " materials; bounds " << formatVec(m.bounds.min)
          << " to " << formatVec(m.bounds.max) << "; " << state.lightCount << " lights\n";
  return 0;
}

}  // namespace myriad::cli
