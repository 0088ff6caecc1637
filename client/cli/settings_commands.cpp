// settings [--sun-dir ...]: PATCH, or GET without options.
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
                    {"technique", s.technique},
                    {"animate", onOff(s.animate)}});
}

}  // namespace

int runSettingsCommand(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string route = ctx.sessionRoute(protocol::routes::kSessionSettings);
  nlohmann::json settings;
  if (inv.options.empty()) {
    settings = ctx.call("GET", route);
  } else {
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
    patch.technique = inv.find<std::string>("technique");
    patch.animate = inv.find<bool>("animate");
    settings = ctx.call("PATCH", route, patch);
  }
  if (!ctx.json()) printSettings(ctx.out, settings.get<protocol::Settings>());
  return 0;
}

}  // namespace myriad::cli
