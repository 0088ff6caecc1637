// The table of subcommands and their options. The bounds mirror protocol/CONTRACT.md so that a
// mistake is caught before a request is sent; the server checks everything again.
#include <array>
#include <limits>
#include <string_view>

#include "args.h"
#include "protocol/constants.h"

namespace myriad::cli {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

const Bounds kLinearColour{0.0, 64.0};  // sun, ambient, background
const Bounds kUnitInterval{0.0, 1.0};   // base colour, metallic, roughness, light colour
const Bounds kFov{1.0, 179.0, false, false, "degrees"};
const Bounds kSunIntensity{0.0, 1000.0};
const Bounds kEnvironmentIntensity{0.0, 1000.0};
const Bounds kEnvironmentRotation{-100.0, 100.0, false, false, "radians"};
const Bounds kExposure{0.0, 1000.0, true};
const Bounds kLightRadius{0.0, 1e4, true};
const Bounds kLightAmount{0.0, 1e4};  // falloff; generated intensities
const Bounds kLightIntensity{0.0, 1e6};
const Bounds kConeAngle{0.0, 1.5707963267948966, false, false, "radians"};
const Bounds kAtLeastOne{1.0, kInf};
const Bounds kQuality{1.0, 100.0};
const Bounds kFps{1.0, 60.0};
const Bounds kLightPage{0.0, 1000.0};  // 0: only the total
const Bounds kSeed{0.0, 9007199254740991.0};  // 2^53-1: exact in a JSON number
const Bounds kCoordinate{-1e6, 1e6};  // every vector component, in scene units
const Bounds kDistance{0.0, 1e6, true};
const Bounds kTime{0.0, 1e6, false, false, "seconds"};
const Bounds kRate{-protocol::query::kMaxClockRate, protocol::query::kMaxClockRate};
const Bounds kObjectId{1.0, 4294967294.0};    // objectId in protocol/schemas/defs.schema.json
const Bounds kMaterialId{0.0, 4294967294.0};  // an object's material
const Bounds kSemantic{0.0, 65535.0};
const Bounds kObjectPage{0.0, 1000.0};  // limits of GET .../objects; 0: only the total

OptionSpec option(std::string name, Kind kind, std::string help,
                  std::optional<Bounds> bounds = std::nullopt, std::string metavar = {}) {
  OptionSpec o;
  o.name = std::move(name);
  o.kind = kind;
  o.help = std::move(help);
  o.bounds = std::move(bounds);
  o.metavar = std::move(metavar);
  return o;
}

OptionSpec choice(std::string name, std::vector<std::string> choices, std::string help) {
  OptionSpec o = option(std::move(name), Kind::Choice, std::move(help));
  o.choices = std::move(choices);
  return o;
}

// A choice among the protocol's own names (protocol::kTechniques, kFormats).
template <size_t N>
OptionSpec choice(std::string name, const std::array<std::string_view, N>& names, std::string help) {
  return choice(std::move(name), std::vector<std::string>(names.begin(), names.end()),
                std::move(help));
}

OptionSpec flag(std::string name, std::string help) {
  return option(std::move(name), Kind::Flag, std::move(help));
}

OptionSpec output(std::string help) {
  OptionSpec o = option("output", Kind::Text, std::move(help), std::nullopt, "PATH");
  o.shortName = 'o';
  o.required = true;
  return o;
}

PositionalSpec positional(std::string name, Kind kind, std::string help, bool optional = false) {
  PositionalSpec p;
  p.name = std::move(name);
  p.kind = kind;
  p.help = std::move(help);
  p.optional = optional;
  return p;
}

// The light members shared by `lights add` and `lights set`.
std::vector<OptionSpec> lightOptions(bool forAdd) {
  OptionSpec position = option("position", Kind::Vector, "centre, scene units", kCoordinate);
  OptionSpec radius = option("radius", Kind::Number, "reach, scene units", kLightRadius);
  position.required = forAdd;
  radius.required = forAdd;
  return {position, radius,
          option("color", Kind::Vector, "linear RGB" + std::string(forAdd ? ", default 1,1,1" : ""),
                 kUnitInterval, "r,g,b"),
          option("intensity", Kind::Number,
                 std::string(forAdd ? "default 1; " : "") + "candela with --attenuation inverse-square",
                 kLightIntensity),
          option("falloff", Kind::Number, "C in (r^2-d^2)/(C d^2 + r^2)", kLightAmount),
          option("attenuation", Kind::Text,
                 "window (default) or inverse-square (glTF's 1/d^2, zero at the radius)",
                 std::nullopt, "MODE"),
          option("spot", Kind::Vector, "make it a spot light pointing this way", kCoordinate, "x,y,z"),
          option("cone", Kind::Range, "a spot's inner,outer cone angles, radians (default 0,0.785)",
                 kConeAngle, "inner,outer"),
          flag("point", "make it a point light again")};
}

PositionalSpec pixel(std::string name, std::string help) {
  PositionalSpec p = positional(std::move(name), Kind::Number, std::move(help));
  p.bounds = Bounds{0.0, 16384.0, false, true, "pixels"};
  return p;
}

void requireSomeOption(const Invocation& inv, const std::string& what) {
  if (inv.options.empty()) throw UsageError(inv.command->name, what);
}

// An asset id as the server makes them: "a-" and 16 lower-case hex digits.
void checkAssetId(const std::string& id, const std::string& what) {
  bool ok = id.size() == 18 && id.starts_with("a-") &&
            id.find_first_not_of("0123456789abcdef", 2) == std::string::npos;
  if (!ok) {
    throw UsageError(what, what + ": \"" + id +
                               "\" is not an asset id (a- and 16 hex digits; see myriad asset list)");
  }
}

// --at, --rotate, --scale: an object's transform (TRS, as glTF), for `object add` and `move`.
std::vector<OptionSpec> transformOptions(const std::string& missing) {
  return {option("at", Kind::Vector, "translation, scene units (" + missing + " 0,0,0)",
                 kCoordinate),
          option("rotate", Kind::Rotation,
                 "rotation quaternion as glTF, normalized by the server (" + missing +
                     " 0,0,0,1)",
                 kCoordinate),
          option("scale", Kind::Scale, "one factor for every axis, or one each (" + missing + " 1)",
                 kCoordinate)};
}

PositionalSpec objectIdPositional() {
  PositionalSpec p = positional("OID", Kind::Unsigned, "the object id from `myriad object list`");
  p.bounds = kObjectId;
  return p;
}

PositionalSpec assetIdPositional(std::string name = "AID") {
  return positional(std::move(name), Kind::Text, "the asset id from `myriad asset list` (a-...)");
}

std::vector<CommandSpec> buildSpecs() {
  std::vector<CommandSpec> specs;

  // Sessions.
  specs.push_back({"session new", "start a session and remember its id:token", {},
                   {option("api-key", Kind::Text, "the server's --api-key (env MYRIAD_API_KEY)",
                           std::nullopt, "KEY"),
                    flag("print-env", "print `export MYRIAD_SESSION=id:token` instead of saving")},
                   "Saves id:token to the session file (mode 0600) unless --print-env is given.",
                   {}});
  specs.push_back({"session show", "the session's model, camera, settings and light count", {}, {},
                   {}, {}});
  specs.push_back({"session delete", "end the session and free its GPU memory", {}, {},
                   "Removes the session file when the session came from it.", {}});
  specs.push_back({"session share", "make a view-only token and print the page link that uses it",
                   {},
                   {option("ttl", Kind::Unsigned, "seconds the token works (default 3600)",
                           Bounds{60.0, 604800.0, false, false, "seconds"}, "SECONDS")},
                   "Whoever opens the link watches the session live and can read it, but every "
                   "change is refused (403). `myriad session unshare` revokes every such token.",
                   {}});
  specs.push_back({"session unshare", "revoke every view-only token of the session", {}, {}, {},
                   {}});
  specs.push_back({"open", "print the web page's address for the session", {}, {},
                   "The link carries the session's own token: whoever has it can change the "
                   "session (share a view-only link with `myriad session share`).",
                   {}});

  // Server-wide.
  specs.push_back({"health", "whether the server answers", {}, {}, {}, {}});
  specs.push_back({"info", "the server, its GPU, limits, techniques and targets", {}, {}, {}, {}});
  specs.push_back({"models", "the models in the server's library (--models DIR)", {}, {}, {}, {}});

  // Model.
  CommandSpec load{"load", "load a model into the session (replaces meshes and materials)",
                   {positional("FILE", Kind::Text,
                               "a model file to upload (glTF, OBJ, ...), or a .zip of a model with "
                               "the files it refers to",
                               true)},
                   {option("library", Kind::Text, "a model from `myriad models`", std::nullopt,
                           "NAME"),
                    option("entry", Kind::Text, "the model file inside FILE.zip, when it holds several",
                           std::nullopt, "PATH"),
                    flag("builtin", "the built-in scene"),
                    flag("model-lights", "also replace the lights with the model's own")},
                   "Give exactly one of FILE, --library NAME, --builtin. A FILE ending in .zip is "
                   "sent as an archive (a .gltf with its .bin and images, an .obj with its .mtl). "
                   "The camera is reset to frame the model.",
                   {}};
  load.check = [](const Invocation& inv) {
    int sources = int(!inv.positionals.empty()) + int(inv.has("library")) + int(inv.has("builtin"));
    if (sources != 1) {
      throw UsageError(sources == 0 ? "load" : "--library",
                       sources == 0 ? "\"load\" needs FILE, --library NAME or --builtin"
                                    : "\"load\" takes only one of FILE, --library NAME, --builtin");
    }
    if (inv.has("entry") && (inv.positionals.empty() ||
                             !std::get<std::string>(inv.positionals[0]).ends_with(".zip"))) {
      throw UsageError("--entry", "--entry names the model inside a FILE.zip");
    }
  };
  specs.push_back(load);

  // Assets: models stored in the session, each drawn by the objects that use it.
  CommandSpec assetAdd{
      "asset add", "add a model to the session's assets (draws nothing until an object uses it)",
      {positional("SOURCE", Kind::Text,
                  "a model file to upload (glTF, OBJ, ...) or a .zip of a model with its files; "
                  "library:NAME (see `myriad models`); builtin:default")},
      {option("entry", Kind::Text, "the model file inside SOURCE.zip, when it holds several",
              std::nullopt, "PATH")},
      "Prints the asset's id, for `myriad object add`. The same file or name again gives the "
      "asset already there. A file whose name starts with library: or builtin: is given as "
      "./NAME.",
      {}};
  assetAdd.check = [](const Invocation& inv) {
    const std::string& source = std::get<std::string>(inv.positionals[0]);
    if (source.starts_with(protocol::kLibraryPrefix) &&
        source.size() == protocol::kLibraryPrefix.size()) {
      throw UsageError("SOURCE", "SOURCE: library: needs the model's name (see myriad models)");
    }
    if (source.starts_with("builtin:") && source != protocol::kBuiltinModel) {
      throw UsageError("SOURCE", "SOURCE: the only built-in model is " +
                                     std::string(protocol::kBuiltinModel));
    }
    if (inv.has("entry") && !source.ends_with(".zip")) {
      throw UsageError("--entry", "--entry names the model inside a SOURCE.zip");
    }
  };
  specs.push_back(assetAdd);
  specs.push_back({"asset list", "list the session's assets", {}, {}, {}, {}});
  CommandSpec assetShow{"asset show", "one asset: its meshes, materials, bounds and users",
                        {assetIdPositional()}, {}, {}, {}};
  assetShow.check = [](const Invocation& inv) {
    checkAssetId(std::get<std::string>(inv.positionals[0]), "AID");
  };
  specs.push_back(assetShow);
  CommandSpec assetDelete{"asset delete", "remove an asset that no object uses",
                          {assetIdPositional()}, {},
                          "Refused (409) while an object draws the asset or one of its materials: "
                          "delete those objects first. The materials of later assets move down.",
                          {}};
  assetDelete.check = assetShow.check;
  specs.push_back(assetDelete);

  // Objects: instances of assets, placed in the scene.
  PositionalSpec assetOfObject = assetIdPositional("ASSET");
  assetOfObject.help = "the asset it draws, from `myriad asset add` or `myriad asset list`";
  std::vector<OptionSpec> objectAddOptions = {
      option("name", Kind::Text, "a name for people (default: the asset's source)",
             std::nullopt, "NAME")};
  for (OptionSpec& o : transformOptions("default")) objectAddOptions.push_back(o);
  objectAddOptions.push_back(option("parent", Kind::Unsigned,
                                    "the object its transform is relative to (default: the world)",
                                    kObjectId, "OID"));
  objectAddOptions.push_back(option("material", Kind::Unsigned,
                                    "a session material drawn instead of the asset's own",
                                    kMaterialId, "MID"));
  objectAddOptions.push_back(option("semantic", Kind::NumberOrName,
                                    "class for the semantic-id label: a number (default 0: none) "
                                    "or a name the session gives an id", kSemantic, "K|NAME"));
  objectAddOptions.push_back(flag("hidden", "add it hidden (`object set OID --visible true` shows it)"));
  CommandSpec objectAdd{"object add", "place an asset in the scene as a new object",
                        {assetOfObject}, objectAddOptions,
                        "Prints the new object's id. The transform is applied scale first, then "
                        "rotation, then translation (glTF's TRS).",
                        {}};
  objectAdd.check = [](const Invocation& inv) {
    checkAssetId(std::get<std::string>(inv.positionals[0]), "ASSET");
  };
  specs.push_back(objectAdd);
  specs.push_back({"object list", "list objects, a page at a time", {},
                   {option("offset", Kind::Unsigned,
                           "skip this many objects of the list (a count, not an id; default 0)"),
                    option("limit", Kind::Unsigned, "how many (default 100)", kObjectPage)},
                   {},
                   {}});
  specs.push_back({"object show", "one object: its asset, transform, visibility and bounds",
                   {objectIdPositional()}, {}, {}, {}});
  std::vector<OptionSpec> moveOptions = transformOptions("default: as it is; with --reset");
  moveOptions.push_back(flag("reset", "members not given go back to the identity's"));
  CommandSpec objectMove{"object move", "change an object's transform (its children move with it)",
                         {objectIdPositional()}, moveOptions,
                         "Members not given keep their values (an object placed by a matrix "
                         "through the API gets the identity's, with a note).",
                         {}};
  objectMove.check = [](const Invocation& inv) {
    requireSomeOption(inv, "\"object move\" needs at least one of --at, --rotate, --scale, --reset");
  };
  specs.push_back(objectMove);
  CommandSpec objectSet{
      "object set", "change the members given of one object", {objectIdPositional()},
      {option("visible", Kind::OnOff, "drawn when its parents are too", std::nullopt,
              "true|false"),
       option("name", Kind::Text, "a name for people", std::nullopt, "NAME"),
       option("asset", Kind::Text, "draw another asset", std::nullopt, "AID"),
       option("parent", Kind::IdOrNone, "the object its transform is relative to; none: the world",
              kObjectId, "OID|none"),
       option("material", Kind::IdOrNone,
              "a session material drawn instead of the asset's; none: the asset's own", kMaterialId,
              "MID|none"),
       option("semantic", Kind::NumberOrName,
              "class for the semantic-id label: a number (0: none) or a name", kSemantic,
              "K|NAME")},
      "Hiding an object hides its children; `object move` changes the transform.",
      {}};
  objectSet.check = [](const Invocation& inv) {
    requireSomeOption(inv, "\"object set\" needs at least one of --visible, --name, --asset, "
                           "--parent, --material, --semantic");
    if (auto asset = inv.find<std::string>("asset")) checkAssetId(*asset, "--asset");
  };
  specs.push_back(objectSet);
  specs.push_back({"object delete", "remove one object and its children", {objectIdPositional()},
                   {}, {}, {}});

  // Camera.
  CommandSpec camera{"camera", "show the camera, or change the members given", {},
                     {option("eye", Kind::Vector, "camera position", kCoordinate),
                      option("target", Kind::Vector, "the point looked at", kCoordinate),
                      option("up", Kind::Vector, "up direction", kCoordinate),
                      option("fov", Kind::Number, "vertical field of view", kFov, "DEG"),
                      option("near", Kind::Number, "near plane distance", kDistance),
                      option("far", Kind::Number, "far plane distance", kDistance)},
                     "Without options, prints the camera.",
                     {}};
  camera.check = [](const Invocation& inv) {
    auto nearPlane = inv.find<double>("near");
    auto farPlane = inv.find<double>("far");
    if (nearPlane && farPlane && *farPlane <= *nearPlane) {
      throw UsageError("--far", "--far must be greater than --near");
    }
  };
  specs.push_back(camera);
  specs.push_back({"camera frame", "point the camera at the whole model", {}, {}, {}, {}});

  // Settings.
  CommandSpec settings{
      "settings", "show the lighting settings, or change the members given", {},
      {option("sun-dir", Kind::Vector, "direction the sunlight travels (normalized by the server)",
              kCoordinate),
       option("sun-color", Kind::Vector, "linear RGB", kLinearColour, "r,g,b"),
       option("sun-intensity", Kind::Number, "sun brightness", kSunIntensity),
       option("ambient", Kind::Vector, "ambient light, linear RGB", kLinearColour, "r,g,b"),
       option("background", Kind::Vector, "background, linear RGB", kLinearColour, "r,g,b"),
       option("exposure", Kind::Number, "exposure before tonemapping", kExposure),
       option("markers", Kind::OnOff, "draw a marker at each light"),
       choice("antialias", protocol::kAntialiasModes, "anti-aliasing of the final image"),
       choice("technique", protocol::kTechniques, "how local lights are assigned"),
       option("animate", Kind::OnOff, "move the lights on the GPU"),
       choice("environment", protocol::kEnvironmentModes,
              "the environment light: none (ambient), sky (follows the sun), hdr"),
       option("env-intensity", Kind::Number, "environment light scale", kEnvironmentIntensity),
       option("env-rotation", Kind::Number, "turn the hdr environment about +Y",
              kEnvironmentRotation, "RAD"),
       option("env-background", Kind::OnOff, "show the environment where no geometry is"),
       option("env-hdr", Kind::Text, "upload an equirectangular Radiance .hdr (selects hdr)",
              std::nullopt, "FILE")},
      "Without options, prints the settings.",
      {}};
  settings.check = [](const Invocation& inv) {
    if (auto d = inv.find<Vec3>("sun-dir"); d && (*d)[0] == 0 && (*d)[1] == 0 && (*d)[2] == 0) {
      throw UsageError("--sun-dir", "--sun-dir must not be 0,0,0");
    }
  };
  specs.push_back(settings);

  // Materials.
  specs.push_back({"materials", "list the model's materials", {}, {}, {}, {}});
  specs.push_back({"material", "show one material, or change the members given",
                   {positional("ID", Kind::Unsigned, "the material id from `myriad materials`")},
                   {option("base-color", Kind::Vector, "linear RGB", kUnitInterval, "r,g,b"),
                    option("metallic", Kind::Number, "metalness", kUnitInterval),
                    option("roughness", Kind::Number, "roughness", kUnitInterval)},
                   {},
                   {}});

  // Lights.
  specs.push_back({"lights list", "list lights, a page at a time", {},
                   {option("offset", Kind::Unsigned,
                           "skip this many lights of the list (a count, not an id; default 0)"),
                    option("limit", Kind::Unsigned, "how many (default 100)", kLightPage)},
                   {},
                   {}});
  specs.push_back({"lights show", "one light", {positional("ID", Kind::Unsigned, "the light id")},
                   {}, {}, {}});
  specs.push_back({"lights pick", "the light whose marker is at a pixel of the view",
                   {pixel("X", "the pixel's column, 0 at the left"),
                    pixel("Y", "the pixel's row, 0 at the top")},
                   {option("width", Kind::Unsigned, "the view's width in pixels (default 1280)",
                           kAtLeastOne),
                    option("height", Kind::Unsigned, "the view's height in pixels (default 720)",
                           kAtLeastOne),
                    option("radius", Kind::Number, "also a marker this many pixels away",
                           Bounds{0.0, 64.0}, "PX")},
                   "Looks among all of the session's lights (the server projects them with the "
                   "session's camera); prints the light, or says no marker is there.",
                   {}});
  specs.push_back({"lights add", "add one light (a point light, or a spot with --spot)", {}, lightOptions(true),
                   "Prints the new light's id.", {}});
  CommandSpec lightsSet{"lights set", "change the members given of one light",
                        {positional("ID", Kind::Unsigned, "the light id")}, lightOptions(false), {},
                        {}};
  lightsSet.check = [](const Invocation& inv) {
    requireSomeOption(inv, "\"lights set\" needs at least one of --position, --radius, --color, "
                           "--intensity, --falloff, --attenuation, --spot, --cone, --point");
  };
  specs.push_back(lightsSet);
  specs.push_back({"lights rm", "remove one light", {positional("ID", Kind::Unsigned, "the light id")},
                   {}, {}, {}});
  specs.push_back({"lights clear", "remove every light", {}, {}, {}, {}});
  PositionalSpec count = positional("N", Kind::Unsigned, "how many lights");
  count.bounds = kAtLeastOne;
  specs.push_back({"lights generate", "scatter N random lights over the model", {count},
                   {option("seed", Kind::Unsigned, "random seed (the same seed, the same lights)",
                           kSeed),
                    option("radius", Kind::Range, "radius range", kLightRadius),
                    option("intensity", Kind::Range, "intensity range", kLightAmount),
                    option("falloff", Kind::Number, "falloff of every light", kLightAmount),
                    flag("keep", "add to the existing lights instead of replacing them")},
                   "Lights fill the model's bounds, grown a little.",
                   {}});

  // Frames.
  std::vector<OptionSpec> frameSize = {
      option("width", Kind::Unsigned, "pixels, at most the server's maxResolution", kAtLeastOne),
      option("height", Kind::Unsigned, "pixels", kAtLeastOne)};
  CommandSpec frame{
      "frame",
      "render one frame of the session to a file",
      {},
      {option("target", Kind::Text,
              "final (default) or a G-buffer or debug view; see "
              "`myriad info`",
              std::nullopt, "T"),
       choice("format", protocol::kFormats, "image format (default png)"), frameSize[0],
       frameSize[1], option("quality", Kind::Unsigned, "JPEG quality", kQuality),
       option("time", Kind::Number,
              "animation time in seconds: the objects' clips and the lights "
              "(default: the session's clocks)",
              kTime),
       output("file to write; - for standard output")},
      "raw is little-endian float32; its channel names and size are printed.",
      {}};
  specs.push_back(frame);
  specs.push_back({"stream", "save frames of the session's live JPEG stream",
                   {},
                   {option("target", Kind::Text, "final (default) or another view", std::nullopt,
                           "T"),
                    choice("format", {"jpeg", "png"}, "image format (default jpeg)"),
                    option("fps", Kind::Unsigned, "most frames a second", kFps),
                    option("frames", Kind::Unsigned, "stop after N frames; default: until interrupted",
                           kAtLeastOne),
                    frameSize[0], frameSize[1],
                    option("quality", Kind::Unsigned, "JPEG quality", kQuality),
                    output("directory for frame-0000.jpg, frame-0001.jpg, ...")},
                   "The server sends a frame when the scene changes or while lights animate, and "
                   "again every 2 s.",
                   {}});
  specs.push_back({"stats", "timings of the last frame, light and GPU memory figures", {}, {}, {},
                   {}});
  // The scene clock (GET/PATCH .../clock).
  specs.push_back(
      {"clock",
       "show the scene clock that objects' animation clips play on, or change it",
       {},
       {option("play", Kind::OnOff, "play (on) or pause (off)", std::nullopt, "on|off"),
        option("time", Kind::Number, "seek: the clock's new time", kTime),
        option("rate", Kind::Number, "clock seconds per second (negative: backwards)", kRate, "R")},
       "Without options, prints the clock. Frames without --time show the scene at its time.",
       {}});
  return specs;
}

}  // namespace

const std::vector<CommandSpec>& commandSpecs() {
  static const std::vector<CommandSpec> specs = buildSpecs();
  return specs;
}

}  // namespace myriad::cli
