// health, info, models: server-wide, no session needed.
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

std::string joined(const std::vector<std::string>& items) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : ", ") + item;
  return text;
}

void printInfo(std::ostream& out, const protocol::Info& info) {
  const protocol::DeviceSummary& d = info.device;
  const protocol::Limits& l = info.limits;
  printFields(out, {
      {"server", info.serverName + " " + info.serverVersion},
      {"device", d.name + " (" + d.type + ", " + d.driverName + ", Vulkan " + d.apiVersion + ")"},
      {"validation", info.validationEnabled
                         ? "on, " + std::to_string(info.validationMessages) + " messages"
                         : "off"},
      {"techniques", joined(info.techniques) + " (default " + info.defaultTechnique + ")"},
      {"targets", joined(info.targets)},
      {"formats", joined(info.formats)},
      {"api key", info.apiKeyRequired ? "required to create sessions" : "not required"},
      {"max resolution", std::to_string(l.maxResolution)},
      {"max sessions", std::to_string(l.maxSessions) + ", idle for " +
                           std::to_string(l.sessionIdleSeconds) + " s at most"},
      {"max lights", std::to_string(l.maxLightsPerSession) + " per session"},
      {"max upload", formatBytes(l.maxUploadBytes)},
      {"max streams", std::to_string(l.maxStreams) +
                          (l.maxStreamsPerSession
                               ? ", " + std::to_string(*l.maxStreamsPerSession) + " per session"
                               : std::string())},
  });
}

}  // namespace

int runServerCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "health") {
    nlohmann::json health = ctx.call("GET", std::string(protocol::routes::kHealth));
    if (!ctx.json()) ctx.out << health.get<protocol::Health>().status << "\n";
    return 0;
  }
  if (name == "info") {
    nlohmann::json info = ctx.call("GET", std::string(protocol::routes::kInfo));
    if (!ctx.json()) printInfo(ctx.out, info.get<protocol::Info>());
    return 0;
  }
  nlohmann::json models = ctx.call("GET", std::string(protocol::routes::kModels));
  if (!ctx.json()) {
    auto list = models.get<protocol::ModelsList>();
    if (list.models.empty()) {
      ctx.out << "no models (the server was started without --models DIR, or it is empty)\n";
      return 0;
    }
    std::vector<std::vector<std::string>> rows;
    for (const auto& m : list.models) rows.push_back({m.name, formatBytes(m.bytes)});
    printTable(ctx.out, {"NAME", "SIZE"}, rows);
  }
  return 0;
}

}  // namespace myriad::cli
