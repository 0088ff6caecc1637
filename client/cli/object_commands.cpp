// object add | list | show | move | set | delete: instances of assets placed in the scene
// (POST/GET .../objects, GET/PATCH/DELETE .../objects/{oid}).
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;
using nlohmann::json;

const std::vector<std::string> kHeader = {"ID",      "NAME",   "ASSET",  "AT",
                                          "SCALE",   "VISIBLE", "PARENT", "INSTANCES"};

// An object's transform as TRS (glTF's: scale, then rotation, then translation).
struct Trs {
  Vec3 translation{0, 0, 0};
  Vec4 rotation{0, 0, 0, 1};  // x, y, z, w
  Vec3 scale{1, 1, 1};
};

json toWire(const Trs& t) {
  return {{"translation", t.translation}, {"rotation", t.rotation}, {"scale", t.scale}};
}

// The object's transform as TRS; nullopt when it was given as a matrix.
std::optional<Trs> trsOf(const json& object) {
  const json& t = object.at("transform");
  if (t.contains("matrix")) return std::nullopt;
  Trs trs;
  if (t.contains("translation")) trs.translation = t.at("translation").get<Vec3>();
  if (t.contains("rotation")) trs.rotation = t.at("rotation").get<Vec4>();
  if (t.contains("scale")) trs.scale = t.at("scale").get<Vec3>();
  return trs;
}

std::string formatVec4(const Vec4& v) {
  return formatNumber(v[0]) + ", " + formatNumber(v[1]) + ", " + formatNumber(v[2]) + ", " +
         formatNumber(v[3]);
}

std::string idOrDash(const json& value) {
  return value.is_null() ? "-" : std::to_string(value.get<uint64_t>());
}

std::string nameOf(const json& object) {
  std::string name = object.at("name").get<std::string>();
  return name.empty() ? "-" : name;
}

std::vector<std::string> objectRow(const json& o) {
  std::optional<Trs> trs = trsOf(o);
  std::string at, scale;
  if (trs) {
    at = formatVec(trs->translation);
    const Vec3& s = trs->scale;
    scale = s[0] == s[1] && s[1] == s[2] ? formatNumber(s[0]) : formatVec(s);
  } else {
    // Column-major: the translation is the last column.
    const auto m = o.at("transform").at("matrix").get<std::vector<double>>();
    at = m.size() == 16 ? formatVec({m[12], m[13], m[14]}) : "?";
    scale = "matrix";
  }
  return {std::to_string(o.at("id").get<uint64_t>()),
          nameOf(o),
          o.at("asset").get<std::string>(),
          at,
          scale,
          o.at("visible").get<bool>() ? "yes" : "no",
          idOrDash(o.at("parent")),
          std::to_string(o.at("instances").get<uint64_t>())};
}

void printObject(std::ostream& out, const json& o) {
  std::vector<std::pair<std::string, std::string>> fields = {
      {"object", std::to_string(o.at("id").get<uint64_t>())},
      {"name", nameOf(o)},
      {"asset", o.at("asset").get<std::string>()}};
  if (std::optional<Trs> trs = trsOf(o)) {
    fields.push_back({"translation", formatVec(trs->translation)});
    fields.push_back({"rotation", formatVec4(trs->rotation) + " (x, y, z, w)"});
    fields.push_back({"scale", formatVec(trs->scale)});
  } else {
    const auto m = o.at("transform").at("matrix").get<std::vector<double>>();
    for (size_t row = 0; row < 4 && m.size() == 16; ++row) {
      fields.push_back({row == 0 ? "matrix" : "",
                        formatVec4({m[row], m[4 + row], m[8 + row], m[12 + row]})});
    }
  }
  const json& material = o.at("material");
  fields.push_back({"visible", o.at("visible").get<bool>() ? "yes" : "no"});
  fields.push_back({"parent", o.at("parent").is_null() ? "none (the world)" : idOrDash(o.at("parent"))});
  fields.push_back({"material", material.is_null() ? "the asset's own" : idOrDash(material)});
  // An integer class, or a class name (the session maps it to an id: GET .../labels lists them).
  const json& semantic = o.at("semantic");
  fields.push_back({"semantic", semantic.is_string() ? semantic.get<std::string>()
                                                     : std::to_string(semantic.get<uint64_t>())});
  fields.push_back({"instances", std::to_string(o.at("instances").get<uint64_t>())});
  if (o.contains("bounds")) {
    const json& b = o.at("bounds");
    fields.push_back({"bounds", "min " + formatVec(b.at("min").get<Vec3>()) + "  max " +
                                    formatVec(b.at("max").get<Vec3>())});
  } else {
    fields.push_back({"bounds", "none (it draws nothing now)"});
  }
  printFields(out, fields);
}

std::string objectRoute(Context& ctx, uint64_t id) {
  return protocol::expandRoute(ctx.sessionRoute(protocol::routes::kSessionObject), "oid",
                               std::to_string(id));
}

uint64_t objectId(const Context& ctx) { return std::get<uint64_t>(ctx.inv.positionals[0]); }

// --at, --rotate, --scale onto `trs`.
void applyTransform(const Invocation& inv, Trs& trs) {
  if (auto at = inv.find<Vec3>("at")) trs.translation = *at;
  if (auto rotate = inv.find<Vec4>("rotate")) trs.rotation = *rotate;
  if (auto scale = inv.find<Vec3>("scale")) trs.scale = *scale;
}

// --semantic: a class number, or a class name the session gives an id (reference.md, Scene).
json semanticOf(const Invocation& inv) {
  const Value& value = inv.options.at("semantic");
  if (const auto* number = std::get_if<uint64_t>(&value)) return *number;
  return std::get<std::string>(value);
}

int add(Context& ctx) {
  const Invocation& inv = ctx.inv;
  json object = {{"asset", std::get<std::string>(inv.positionals[0])}};
  if (auto name = inv.find<std::string>("name")) object["name"] = *name;
  if (inv.has("at") || inv.has("rotate") || inv.has("scale")) {
    Trs trs;
    applyTransform(inv, trs);
    object["transform"] = toWire(trs);
  }
  if (inv.has("hidden")) object["visible"] = false;
  if (auto parent = inv.find<uint64_t>("parent")) object["parent"] = *parent;
  if (auto material = inv.find<uint64_t>("material")) object["material"] = *material;
  if (inv.has("semantic")) object["semantic"] = semanticOf(inv);
  json added = ctx.call("POST", ctx.sessionRoute(protocol::routes::kSessionObjects),
                        json{{"objects", json::array({object})}});
  if (!ctx.json()) {
    const json& ids = added.at("ids");
    if (ids.size() != 1) throw ApiError("the server did not return the new object's id");
    ctx.out << "added object " << ids[0].get<uint64_t>() << " ("
            << added.at("total").get<uint64_t>() << " objects)\n";
  }
  return 0;
}

int list(Context& ctx) {
  Query query;
  if (auto offset = ctx.inv.find<uint64_t>("offset")) {
    query.emplace_back("offset", std::to_string(*offset));
  }
  if (auto limit = ctx.inv.find<uint64_t>("limit")) {
    query.emplace_back("limit", std::to_string(*limit));
  }
  json page = ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionObjects), nullptr, query);
  if (ctx.json()) return 0;
  const json& objects = page.at("objects");
  const uint64_t total = page.at("total").get<uint64_t>();
  const uint64_t offset = page.at("offset").get<uint64_t>();
  std::vector<std::vector<std::string>> rows;
  for (const json& o : objects) rows.push_back(objectRow(o));
  if (!rows.empty()) printTable(ctx.out, kHeader, rows);
  // As `lights list`: objects are named by their ids (the ID column); the page's place in the
  // list is the --offset that continues it.
  ctx.out << objects.size() << " of " << total << " objects";
  const uint64_t next = offset + objects.size();
  if (next < total) ctx.out << "; more with --offset " << next;
  ctx.out << "\n";
  return 0;
}

// PATCH the transform: the members given, the others as they are (GET first) unless --reset.
// The read and the write are one edit: the PATCH carries the GET's ETag as If-Match, and a 412
// (someone changed the session in between) reads again, at most kMoveAttempts times, so a
// member another client just set is never written back with its old value.
int move(Context& ctx) {
  constexpr int kMoveAttempts = 3;
  const Invocation& inv = ctx.inv;
  const uint64_t id = objectId(ctx);
  const std::optional<std::string> userTag = ctx.http.ifMatch();
  for (int attempt = 1;; ++attempt) {
    Trs trs;
    if (!inv.has("reset")) {
      // Not printed under --json: the PATCH's answer is the result.
      json current = ctx.http.sendJson("GET", objectRoute(ctx, id));
      if (std::optional<Trs> was = trsOf(current)) {
        trs = *was;
      } else if (!(inv.has("at") && inv.has("rotate") && inv.has("scale"))) {
        ctx.err << "myriad: note: object " << id
                << " was placed by a matrix; the members not given are the identity's\n";
      }
      // --if-match given: the user's version is the condition, and a 412 is theirs to handle.
      if (!userTag) ctx.http.setIfMatch(ctx.http.lastETag());
    }
    applyTransform(inv, trs);
    try {
      json object = ctx.call("PATCH", objectRoute(ctx, id), json{{"transform", toWire(trs)}});
      ctx.http.setIfMatch(userTag);
      if (!ctx.json()) printObject(ctx.out, object);
      return 0;
    } catch (const ApiError& e) {
      ctx.http.setIfMatch(userTag);
      if (e.status() != 412 || userTag || inv.has("reset") || attempt == kMoveAttempts) throw;
    }
  }
}

int set(Context& ctx) {
  const Invocation& inv = ctx.inv;
  json patch = json::object();
  if (auto visible = inv.find<bool>("visible")) patch["visible"] = *visible;
  if (auto name = inv.find<std::string>("name")) patch["name"] = *name;
  if (auto asset = inv.find<std::string>("asset")) patch["asset"] = *asset;
  if (inv.has("semantic")) patch["semantic"] = semanticOf(inv);
  // none: null, the world or the asset's own materials.
  for (const char* member : {"parent", "material"}) {
    if (auto value = inv.find<std::optional<uint64_t>>(member)) {
      patch[member] = *value ? json(**value) : json(nullptr);
    }
  }
  json object = ctx.call("PATCH", objectRoute(ctx, objectId(ctx)), patch);
  if (!ctx.json()) printObject(ctx.out, object);
  return 0;
}

}  // namespace

int runObjectCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "object add") return add(ctx);
  if (name == "object list") return list(ctx);
  if (name == "object move") return move(ctx);
  if (name == "object set") return set(ctx);
  if (name == "object show") {
    json object = ctx.call("GET", objectRoute(ctx, objectId(ctx)));
    if (!ctx.json()) printObject(ctx.out, object);
    return 0;
  }
  const uint64_t id = objectId(ctx);  // object delete
  ctx.call("DELETE", objectRoute(ctx, id));
  if (!ctx.json()) ctx.out << "deleted object " << id << " (and its children, if any)\n";
  return 0;
}

}  // namespace myriad::cli
