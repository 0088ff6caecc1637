// lights list | show | add | set | rm | clear | generate.
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

const std::vector<std::string> kHeader = {"ID",        "POSITION", "RADIUS",
                                          "COLOR",     "INTENSITY", "FALLOFF"};

std::vector<std::string> lightRow(const protocol::Light& l) {
  return {std::to_string(l.id),  formatVec(l.position),      formatNumber(l.radius),
          formatVec(l.color),    formatNumber(l.intensity),  formatNumber(l.falloff)};
}

// A spot's or an inverse-square light's members, said under the table (the columns stay as they
// were for scripts that read them).
void describeShape(std::ostream& out, const protocol::Light& l) {
  if (l.type == protocol::light_types::kSpot) {
    out << "light " << l.id << ": spot towards " << formatVec(l.direction) << ", cone "
        << formatNumber(l.innerConeAngle) << " to " << formatNumber(l.outerConeAngle) << " rad";
    if (l.attenuation != protocol::attenuations::kWindow) out << ", " << l.attenuation;
    out << "\n";
  } else if (l.attenuation != protocol::attenuations::kWindow) {
    out << "light " << l.id << ": " << l.attenuation << "\n";
  }
}

// --attenuation, --spot, --cone and --point onto a light or a patch (both have the optionals).
template <class T>
void applyShape(const Invocation& inv, T& light) {
  if (auto mode = inv.find<std::string>("attenuation")) {
    if (*mode != protocol::attenuations::kWindow && *mode != protocol::attenuations::kInverseSquare) {
      throw UsageError("--attenuation", "--attenuation is window or inverse-square, not \"" + *mode + "\".",
                       inv.command->name);
    }
    light.attenuation = *mode;
  }
  if (inv.has("point") && (inv.has("spot") || inv.has("cone"))) {
    throw UsageError("--point", "--point goes with neither --spot nor --cone.", inv.command->name);
  }
  if (inv.has("point")) light.type = std::string(protocol::light_types::kPoint);
  if (auto direction = inv.find<Vec3>("spot")) {
    light.type = std::string(protocol::light_types::kSpot);
    light.direction = *direction;
  }
  if (auto cone = inv.find<Interval>("cone")) {
    light.innerConeAngle = cone->min;
    light.outerConeAngle = cone->max;
  }
}

std::string lightRoute(Context& ctx, uint64_t id) {
  return protocol::expandRoute(ctx.sessionRoute(protocol::routes::kSessionLight), "lid",
                               std::to_string(id));
}

int list(Context& ctx) {
  Query query;
  if (auto offset = ctx.inv.find<uint64_t>("offset")) {
    query.emplace_back("offset", std::to_string(*offset));
  }
  if (auto limit = ctx.inv.find<uint64_t>("limit")) {
    query.emplace_back("limit", std::to_string(*limit));
  }
  nlohmann::json page =
      ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionLights), nullptr, query);
  if (ctx.json()) return 0;
  auto lights = page.get<protocol::LightsPage>();
  std::vector<std::vector<std::string>> rows;
  for (const auto& l : lights.lights) rows.push_back(lightRow(l));
  if (!rows.empty()) printTable(ctx.out, kHeader, rows);
  for (const auto& l : lights.lights) describeShape(ctx.out, l);
  // Lights are named by their ids only (the ID column); the page's place in the list is given as
  // the --offset that continues it, never as numbers that could pass for ids.
  ctx.out << lights.lights.size() << " of " << lights.total << " lights";
  const uint64_t next = lights.offset + lights.lights.size();
  if (next < lights.total) ctx.out << "; more with --offset " << next;
  ctx.out << "\n";
  return 0;
}

int add(Context& ctx) {
  const Invocation& inv = ctx.inv;
  protocol::LightNew light;
  light.position = inv.get<Vec3>("position");
  light.radius = inv.get<double>("radius");
  light.color = inv.find<Vec3>("color").value_or(Vec3{1, 1, 1});
  light.intensity = inv.find<double>("intensity").value_or(1.0);
  light.falloff = inv.find<double>("falloff").value_or(0.0);
  applyShape(inv, light);
  protocol::LightsAdd body;
  body.lights.push_back(light);
  nlohmann::json added =
      ctx.call("POST", ctx.sessionRoute(protocol::routes::kSessionLights), body);
  if (!ctx.json()) {
    auto result = added.get<protocol::LightsAdded>();
    if (result.ids.size() != 1) throw ApiError("the server did not return the new light's id");
    ctx.out << "added light " << result.ids[0] << " (" << result.total << " lights)\n";
  }
  return 0;
}

int set(Context& ctx) {
  const Invocation& inv = ctx.inv;
  protocol::LightPatch patch;
  patch.position = inv.find<Vec3>("position");
  patch.radius = inv.find<double>("radius");
  patch.color = inv.find<Vec3>("color");
  patch.intensity = inv.find<double>("intensity");
  patch.falloff = inv.find<double>("falloff");
  applyShape(inv, patch);
  nlohmann::json light =
      ctx.call("PATCH", lightRoute(ctx, std::get<uint64_t>(inv.positionals[0])), patch);
  if (!ctx.json()) {
    const auto changed = light.get<protocol::Light>();
    printTable(ctx.out, kHeader, {lightRow(changed)});
    describeShape(ctx.out, changed);
  }
  return 0;
}

int generate(Context& ctx) {
  const Invocation& inv = ctx.inv;
  protocol::LightsGenerate request;
  request.count = std::get<uint64_t>(inv.positionals[0]);
  request.seed = inv.find<uint64_t>("seed").value_or(0);
  if (inv.has("keep")) request.replace = false;
  if (auto r = inv.find<Interval>("radius")) request.radius = protocol::Range{r->min, r->max};
  if (auto r = inv.find<Interval>("intensity")) request.intensity = protocol::Range{r->min, r->max};
  request.falloff = inv.find<double>("falloff");
  nlohmann::json generated =
      ctx.call("POST", ctx.sessionRoute(protocol::routes::kSessionLightsGenerate), request);
  if (!ctx.json()) {
    ctx.out << "generated " << request.count << " lights (seed " << request.seed << "); "
            << generated.get<protocol::LightsGenerated>().total << " lights in the session\n";
  }
  return 0;
}

// lights pick X Y: the server looks among every light (GET .../lights/pick).
int pick(Context& ctx) {
  const Invocation& inv = ctx.inv;
  auto number = [](double v) { return formatNumber(v); };
  Query query = {{"x", number(std::get<double>(inv.positionals[0]))},
                 {"y", number(std::get<double>(inv.positionals[1]))},
                 {"width", std::to_string(inv.find<uint64_t>("width").value_or(1280))},
                 {"height", std::to_string(inv.find<uint64_t>("height").value_or(720))}};
  if (auto radius = inv.find<double>("radius")) query.emplace_back("radius", number(*radius));
  nlohmann::json answer =
      ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionLightsPick), nullptr, query);
  if (ctx.json()) return 0;
  const auto picked = answer.get<protocol::LightPick>();
  if (!picked.light) {
    ctx.out << "no light's marker at " << query[0].second << "," << query[1].second << "\n";
    return 0;
  }
  printTable(ctx.out, kHeader, {lightRow(*picked.light)});
  describeShape(ctx.out, *picked.light);
  ctx.out << "light " << picked.light->id << ": its marker is " << formatNumber(*picked.distance)
          << " px from the pixel (" << picked.candidates << " within reach)\n";
  return 0;
}

}  // namespace

int runLightsCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "lights list") return list(ctx);
  if (name == "lights pick") return pick(ctx);
  if (name == "lights add") return add(ctx);
  if (name == "lights set") return set(ctx);
  if (name == "lights generate") return generate(ctx);
  if (name == "lights show") {
    nlohmann::json light =
        ctx.call("GET", lightRoute(ctx, std::get<uint64_t>(ctx.inv.positionals[0])));
    if (!ctx.json()) {
      const auto shown = light.get<protocol::Light>();
      printTable(ctx.out, kHeader, {lightRow(shown)});
      describeShape(ctx.out, shown);
    }
    return 0;
  }
  if (name == "lights rm") {
    uint64_t id = std::get<uint64_t>(ctx.inv.positionals[0]);
    ctx.call("DELETE", lightRoute(ctx, id));
    if (!ctx.json()) ctx.out << "removed light " << id << "\n";
    return 0;
  }
  ctx.call("DELETE", ctx.sessionRoute(protocol::routes::kSessionLights));  // lights clear
  if (!ctx.json()) ctx.out << "removed every light\n";
  return 0;
}

}  // namespace myriad::cli
