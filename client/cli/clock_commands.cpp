// clock [--play on|off] [--time s] [--rate R]: the scene clock (PATCH, or GET without options).
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {

int runClockCommand(Context& ctx) {
  namespace protocol = myriad::protocol;
  const Invocation& inv = ctx.inv;
  const std::string route = ctx.sessionRoute(protocol::routes::kSessionClock);
  nlohmann::json answer;
  if (inv.options.empty()) {
    answer = ctx.call("GET", route);
  } else {
    protocol::ClockPatch patch;
    patch.playing = inv.find<bool>("play");
    patch.time = inv.find<double>("time");
    patch.rate = inv.find<double>("rate");
    answer = ctx.call("PATCH", route, patch);
  }
  if (!ctx.json()) {
    const auto clock = answer.get<protocol::Clock>();
    printFields(ctx.out, {{"time", formatNumber(clock.time) + " s"},
                          {"playing", clock.playing ? "yes" : "no"},
                          {"rate", formatNumber(clock.rate)},
                          {"longest clip", formatNumber(clock.duration) + " s"}});
  }
  return 0;
}

}  // namespace myriad::cli
