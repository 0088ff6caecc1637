// settings [--sun-dir ...]: PATCH, or GET without options.
#include <fstream>
#include <iterator>

#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

void printSettings(std::ostream& out, const protocol::Settings& s) {
  printFields(out, {{"sun direction", formatVec(s.sun.direction)},
                    {"sun color", formatVec(s.sun.color)},
                    {"sun intensity", formatNumber(s.sun.intensity)},
                    {"ambient", formatVec(s.ambient)},
                    {"background", formatVec(s.background)},
                    {"exposure", formatNumber(s.exposure)},
                    {"markers", onOff(s.markers)},
                    {"antialias", s.antialias.value_or(std::string(protocol::antialias_modes::kFxaa))},
                    {"technique", s.technique},
                    {"animate", onOff(s.animate)},
                    {"environment", s.environment.mode},
                    {"env intensity", formatNumber(s.environment.intensity)},
                    {"env rotation", formatNumber(s.environment.rotation)},
                    {"env visible", onOff(s.environment.background)}});
}

}  // namespace

int runSettingsCommand(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string route = ctx.sessionRoute(protocol::routes::kSessionSettings);
  nlohmann::json settings;
  if (inv.has("env-hdr")) {
    // The image first (PUT .../environment selects mode hdr), then the other members, if any.
    const std::string path = inv.get<std::string>("env-hdr");
    std::ifstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error("cannot read " + path);
    const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    const size_t slash = path.find_last_of('/');
    HttpResponse res = ctx.http.sendOk(
        "PUT", ctx.sessionRoute(protocol::routes::kSessionEnvironment),
        {{"filename", slash == std::string::npos ? path : path.substr(slash + 1)}}, bytes,
        std::string(protocol::kRadianceContentType));
    settings = nlohmann::json::parse(res.body);
    if (ctx.json() && inv.options.size() == 1) printRaw(ctx.out, res.body);
  }
  if (inv.options.empty()) {
    settings = ctx.call("GET", route);
  } else if (inv.options.size() > (inv.has("env-hdr") ? 1u : 0u)) {
    protocol::SettingsPatch patch;
    if (inv.has("sun-dir") || inv.has("sun-color") || inv.has("sun-intensity")) {
      protocol::SunPatch sun;
      sun.direction = inv.find<Vec3>("sun-dir");
      sun.color = inv.find<Vec3>("sun-color");
      sun.intensity = inv.find<double>("sun-intensity");
      patch.sun = sun;
    }
    patch.ambient = inv.find<Vec3>("ambient");
    patch.background = inv.find<Vec3>("background");
    patch.exposure = inv.find<double>("exposure");
    patch.markers = inv.find<bool>("markers");
    patch.antialias = inv.find<std::string>("antialias");
    patch.technique = inv.find<std::string>("technique");
    patch.animate = inv.find<bool>("animate");
    if (inv.has("environment") || inv.has("env-intensity") || inv.has("env-rotation") ||
        inv.has("env-background")) {
      protocol::EnvironmentPatch environment;
      environment.mode = inv.find<std::string>("environment");
      environment.intensity = inv.find<double>("env-intensity");
      environment.rotation = inv.find<double>("env-rotation");
      environment.background = inv.find<bool>("env-background");
      patch.environment = environment;
    }
    settings = ctx.call("PATCH", route, patch);
  }
  if (!ctx.json()) printSettings(ctx.out, settings.get<protocol::Settings>());
  return 0;
}

}  // namespace myriad::cli
