// materials (list), material ID [--base-color ...] (PATCH; without options, shows that one).
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

std::vector<std::string> materialRow(const protocol::Material& m) {
  return {std::to_string(m.id), m.name.empty() ? "-" : m.name, formatVec(m.baseColor),
          formatNumber(m.metallic), formatNumber(m.roughness)};
}

const std::vector<std::string> kHeader = {"ID", "NAME", "BASE COLOR", "METALLIC", "ROUGHNESS"};

}  // namespace

int runMaterialCommand(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string listRoute = ctx.sessionRoute(protocol::routes::kSessionMaterials);
  if (inv.command->name == "materials") {
    nlohmann::json list = ctx.call("GET", listRoute);
    if (!ctx.json()) {
      std::vector<std::vector<std::string>> rows;
      for (const auto& m : list.get<protocol::MaterialsList>().materials) {
        rows.push_back(materialRow(m));
      }
      printTable(ctx.out, kHeader, rows);
    }
    return 0;
  }

  const uint64_t id = std::get<uint64_t>(inv.positionals[0]);
  if (inv.options.empty()) {
    // There is no GET for one material: pick it out of the list.
    std::string raw;
    nlohmann::json list = ctx.http.sendJson("GET", listRoute, nullptr, {}, &raw);
    for (const auto& m : list.get<protocol::MaterialsList>().materials) {
      if (m.id != id) continue;
      if (ctx.json()) {
        printRaw(ctx.out, nlohmann::json(m).dump());
      } else {
        printTable(ctx.out, kHeader, {materialRow(m)});
      }
      return 0;
    }
    throw ApiError("the session has no material " + std::to_string(id) +
                   " (see `myriad materials`)");
  }
  protocol::MaterialPatch patch;
  patch.baseColor = inv.find<Vec3>("base-color");
  patch.metallic = inv.find<double>("metallic");
  patch.roughness = inv.find<double>("roughness");
  std::string route = protocol::expandRoute(protocol::routes::kSessionMaterial, "id",
                                            percentEncode(ctx.session().id));
  route = protocol::expandRoute(route, "mid", std::to_string(id));
  nlohmann::json material = ctx.call("PATCH", route, patch);
  if (!ctx.json()) printTable(ctx.out, kHeader, {materialRow(material.get<protocol::Material>())});
  return 0;
}

}  // namespace myriad::cli
