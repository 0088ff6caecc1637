#include "commands.h"

#include "output.h"
#include "protocol/constants.h"

namespace myriad::cli {

const SessionRef& Context::session() {
  if (!session_) {
    session_ = findSession(inv.global);
    http.setBearer(session_->token);
  }
  return *session_;
}

std::string Context::sessionRoute(std::string_view route) {
  return protocol::expandRoute(route, "id", percentEncode(session().id));
}

nlohmann::json Context::call(const std::string& method, const std::string& path,
                             const nlohmann::json& body, const Query& query) {
  std::string raw;
  nlohmann::json answer = http.sendJson(method, path, body, query, &raw);
  if (json()) printRaw(out, raw);
  return answer;
}

int runCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  auto group = [&](const char* prefix) {
    return name == prefix || name.starts_with(std::string(prefix) + " ");
  };
  if (group("session") || name == "open") return runSessionCommand(ctx);
  if (name == "health" || name == "info" || name == "models") return runServerCommand(ctx);
  if (name == "load") return runModelCommand(ctx);
  if (group("asset")) return runAssetCommand(ctx);
  if (group("object")) return runObjectCommand(ctx);
  if (group("camera")) return runCameraCommand(ctx);
  if (name == "settings") return runSettingsCommand(ctx);
  if (name == "materials" || name == "material") return runMaterialCommand(ctx);
  if (group("lights")) return runLightsCommand(ctx);
  if (name == "frame" || name == "stream" || name == "stats") return runFrameCommand(ctx);
  if (name == "clock") return runClockCommand(ctx);
  throw std::logic_error("no handler for the command \"" + name + "\"");
}

}  // namespace myriad::cli
