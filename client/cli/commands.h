// What each subcommand does, given a parsed Invocation: one run* function per command group, each
// in its own file, all sharing the Context (the server connection and the session, found lazily
// so that `myriad health` needs no session).
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "args.h"
#include "http.h"
#include "session_store.h"

namespace myriad::cli {

class Context {
 public:
  Context(const Invocation& invocation, HttpClient& http, std::ostream& out, std::ostream& err)
      : inv(invocation), http(http), out(out), err(err) {}

  const Invocation& inv;
  HttpClient& http;
  std::ostream& out;  // results
  std::ostream& err;  // notes that must not mix with results (frame -o -)

  bool json() const { return inv.global.json; }

  // The session (MYRIAD_SESSION or the session file); sets the bearer token on first use.
  const SessionRef& session();

  // A session route template (protocol/constants.h routes::) with {id} filled in.
  std::string sessionRoute(std::string_view route);

  // A request whose JSON answer is printed raw under --json (and returned either way).
  nlohmann::json call(const std::string& method, const std::string& path,
                      const nlohmann::json& body = nullptr, const Query& query = {});

 private:
  std::optional<SessionRef> session_;
};

// A model to send: a file to upload (a .zip as an archive, `entry` naming the model inside), or
// else a source name sent as JSON ("library:NAME", "builtin:default").
struct ModelRequest {
  std::optional<std::string> path;
  std::string source;
  std::optional<std::string> entry;
};

// Sends `model` with `method` to `route` (PUT .../model for `load`, POST .../assets for `asset
// add`), `query` added to what the model needs (?filename=, ?entry=). A status of 400 or more
// throws ApiError; so does a file that cannot be read. An upload that the server cut off before
// answering is said to be over the server's maxUploadBytes when it is.
HttpResponse sendModel(Context& ctx, const std::string& method, const std::string& route,
                       const ModelRequest& model, Query query = {});

// Each returns the exit status (0); failures throw ApiError, UsageError or std::runtime_error.
int runSessionCommand(Context& ctx);   // session new|show|delete|share|unshare, open
int runServerCommand(Context& ctx);    // health, info, models
int runModelCommand(Context& ctx);     // load
int runAssetCommand(Context& ctx);     // asset add|list|show|delete
int runObjectCommand(Context& ctx);    // object add|list|show|move|set|delete
int runCameraCommand(Context& ctx);    // camera, camera frame
int runSettingsCommand(Context& ctx);  // settings
int runMaterialCommand(Context& ctx);  // materials, material
int runLightsCommand(Context& ctx);    // lights ...
int runFrameCommand(Context& ctx);     // frame, stream, stats
int runClockCommand(Context& ctx);     // clock

// Picks the group by the command's name.
int runCommand(Context& ctx);

}  // namespace myriad::cli
