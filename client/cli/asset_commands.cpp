// asset add | list | show | delete: the models stored in the session (POST/GET .../assets,
// GET/DELETE .../assets/{aid}). An asset draws nothing until an object uses it (object_commands).
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;
using nlohmann::json;

const std::vector<std::string> kHeader = {"ID",     "SOURCE",  "MESHES", "INSTANCES",
                                          "MATERIAL IDS", "IMAGES", "OBJECTS", "SIZE"};

uint64_t count(const json& asset, const char* member) { return asset.at(member).get<uint64_t>(); }

// "0-3" for the session material ids first..first+count-1; "-" for none.
std::string materialIds(const json& asset) {
  const uint64_t first = asset.at("materials").at("first").get<uint64_t>();
  const uint64_t n = asset.at("materials").at("count").get<uint64_t>();
  if (n == 0) return "-";
  if (n == 1) return std::to_string(first);
  return std::to_string(first) + "-" + std::to_string(first + n - 1);
}

std::string bytesText(const json& asset) {
  const uint64_t bytes = count(asset, "bytes");
  return bytes == 0 ? "-" : formatBytes(bytes);  // 0: a builtin or library model, not an upload
}

std::string boundsText(const json& asset) {
  if (!asset.contains("bounds")) return "none (the asset is empty)";
  const json& b = asset.at("bounds");
  return "min " + formatVec(b.at("min").get<Vec3>()) + "  max " + formatVec(b.at("max").get<Vec3>());
}

std::vector<std::string> assetRow(const json& a) {
  return {a.at("id").get<std::string>(),          a.at("source").get<std::string>(),
          std::to_string(count(a, "meshes")),     std::to_string(count(a, "instances")),
          materialIds(a),                         std::to_string(count(a, "images")),
          std::to_string(count(a, "objects")),    bytesText(a)};
}

// "upload:spider.obj: 1 meshes, 1 instances, 2 materials (ids 0-1), 3 images"
std::string summary(const json& a) {
  const uint64_t materials = a.at("materials").at("count").get<uint64_t>();
  std::string text = a.at("source").get<std::string>() + ": " +
                     std::to_string(count(a, "meshes")) + " meshes, " +
                     std::to_string(count(a, "instances")) + " instances, " +
                     std::to_string(materials) + " materials";
  if (materials != 0) text += " (ids " + materialIds(a) + ")";
  return text + ", " + std::to_string(count(a, "images")) + " images";
}

void printAsset(std::ostream& out, const json& a) {
  const uint64_t objects = count(a, "objects");
  const uint64_t materials = a.at("materials").at("count").get<uint64_t>();
  printFields(out, {
      {"asset", a.at("id").get<std::string>()},
      {"source", a.at("source").get<std::string>()},
      {"size", bytesText(a)},
      {"meshes", std::to_string(count(a, "meshes"))},
      {"instances", std::to_string(count(a, "instances")) + " per object"},
      {"materials", materials == 0 ? "none"
                                   : std::to_string(materials) + " (session ids " +
                                         materialIds(a) + ")"},
      {"images", std::to_string(count(a, "images"))},
      {"bounds", boundsText(a)},
      {"objects", objects == 0 ? "none use it"
                               : std::to_string(objects) + " use it (delete them to delete it)"},
  });
}

std::string assetRoute(Context& ctx, const std::string& id) {
  return protocol::expandRoute(ctx.sessionRoute(protocol::routes::kSessionAsset), "aid",
                               percentEncode(id));
}

int add(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string& source = std::get<std::string>(inv.positionals[0]);
  ModelRequest model;
  if (source == protocol::kBuiltinModel || source.starts_with(protocol::kLibraryPrefix)) {
    model.source = source;
  } else {
    model.path = source;
    model.entry = inv.find<std::string>("entry");
  }
  HttpResponse res =
      sendModel(ctx, "POST", ctx.sessionRoute(protocol::routes::kSessionAssets), model);
  if (ctx.json()) {
    printRaw(ctx.out, res.body);
    return 0;
  }
  json asset = json::parse(res.body, nullptr, false);
  if (asset.is_discarded()) throw ApiError("the server's answer to the asset upload is not JSON");
  const std::string id = asset.at("id").get<std::string>();
  // 201: a new asset; 200: the same bytes or name were added before.
  if (res.status == 201) {
    ctx.out << "added asset " << id << " (" << summary(asset) << ")\n";
  } else {
    ctx.out << "asset " << id << " was already in the session (" << summary(asset) << ")\n";
  }
  return 0;
}

int list(Context& ctx) {
  json list = ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionAssets));
  if (ctx.json()) return 0;
  const json& assets = list.at("assets");
  if (assets.empty()) {
    ctx.out << "no assets (add one with `myriad asset add`)\n";
    return 0;
  }
  std::vector<std::vector<std::string>> rows;
  for (const json& a : assets) rows.push_back(assetRow(a));
  printTable(ctx.out, kHeader, rows);
  return 0;
}

}  // namespace

int runAssetCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "asset add") return add(ctx);
  if (name == "asset list") return list(ctx);
  const std::string& id = std::get<std::string>(ctx.inv.positionals[0]);
  if (name == "asset show") {
    json asset = ctx.call("GET", assetRoute(ctx, id));
    if (!ctx.json()) printAsset(ctx.out, asset);
    return 0;
  }
  ctx.call("DELETE", assetRoute(ctx, id));  // asset delete
  if (!ctx.json()) ctx.out << "deleted asset " << id << "\n";
  return 0;
}

}  // namespace myriad::cli
