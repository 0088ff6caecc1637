// The command line without a server: every kind of value, ranges at and past their ends, unknown
// flags, missing values, and the checks across options.
#include <doctest/doctest.h>

#include "args.h"

using namespace myriad::cli;

namespace {

Invocation parse(std::initializer_list<const char*> args) {
  std::vector<std::string> list(args.begin(), args.end());
  return parseArguments(list);
}

// The UsageError that parsing `args` throws; fails the test when none is thrown.
UsageError usageError(std::initializer_list<const char*> args) {
  std::vector<std::string> list(args.begin(), args.end());
  try {
    parseArguments(list);
  } catch (const UsageError& e) {
    return e;
  }
  FAIL("no UsageError for the arguments");
  return UsageError("", "");
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE("every command in the table has help that names its options") {
  CHECK(commandSpecs().size() == 37);
  for (const CommandSpec& c : commandSpecs()) {
    INFO(c.name);
    std::string help = commandHelp(c);
    CHECK(help.starts_with("usage: myriad " + c.name));
    for (const OptionSpec& o : c.options) {
      CHECK(contains(help, o.shortName != 0 ? std::string("-") + o.shortName : "--" + o.name));
    }
    CHECK(contains(overviewHelp(), c.name));
  }
}

TEST_CASE("vectors: three finite numbers, negatives taken as values") {
  Invocation inv = parse({"camera", "--eye", "-1,2.5,3e2", "--target=0,0,0", "--up", "0,1,0"});
  REQUIRE(inv.command != nullptr);
  CHECK(inv.command->name == "camera");
  CHECK(inv.get<Vec3>("eye") == Vec3{-1, 2.5, 300});
  CHECK(inv.get<Vec3>("target") == Vec3{0, 0, 0});
  CHECK(inv.get<Vec3>("up") == Vec3{0, 1, 0});

  for (const char* bad : {"1,2", "1,2,3,4", "1,,3", "a,b,c", "1,2,nan", "1,inf,2", "0x10,1,1",
                          "", "1 2 3"}) {
    INFO(bad);
    UsageError e = usageError({"camera", "--eye", bad});
    CHECK(e.argument() == "--eye");
    CHECK(e.command() == "camera");
  }
  CHECK(contains(usageError({"camera", "--eye", "1,2"}).what(), "three numbers"));
  CHECK(contains(usageError({"camera", "--eye", "1,2,nan"}).what(), "finite number"));
}

TEST_CASE("--fov is 1..179 degrees; 0 and 180 are refused") {
  CHECK(parse({"camera", "--fov", "1"}).get<double>("fov") == 1.0);
  CHECK(parse({"camera", "--fov", "179"}).get<double>("fov") == 179.0);
  CHECK(parse({"camera", "--fov", "45.5"}).get<double>("fov") == 45.5);
  for (const char* bad : {"0", "180", "0.999", "179.01", "-45", "1e3"}) {
    INFO(bad);
    UsageError e = usageError({"camera", "--fov", bad});
    CHECK(e.argument() == "--fov");
    CHECK(contains(e.what(), "out of range"));
    CHECK(contains(e.what(), "from 1 to 179 degrees"));
  }
}

TEST_CASE("camera near/far: positive, far beyond near") {
  CHECK(parse({"camera", "--near", "0.01", "--far", "100"}).get<double>("far") == 100.0);
  CHECK(usageError({"camera", "--near", "0"}).argument() == "--near");
  CHECK(usageError({"camera", "--far", "-1"}).argument() == "--far");
  CHECK(usageError({"camera", "--far", "2e6"}).argument() == "--far");
  CHECK(usageError({"camera", "--eye", "0,1e7,0"}).argument() == "--eye");
  CHECK(parse({"camera", "--eye", "-1e6,0,1e6"}).get<Vec3>("eye")[0] == -1e6);
  UsageError e = usageError({"camera", "--near", "5", "--far", "5"});
  CHECK(e.argument() == "--far");
  CHECK(contains(e.what(), "greater than --near"));
}

TEST_CASE("camera frame is its own command; camera alone shows") {
  CHECK(parse({"camera", "frame"}).command->name == "camera frame");
  Invocation show = parse({"camera"});
  CHECK(show.command->name == "camera");
  CHECK(show.options.empty());
  UsageError e = usageError({"camera", "frame", "--eye", "1,2,3"});
  CHECK(e.argument() == "--eye");
  CHECK(contains(e.what(), "unknown option --eye for \"camera frame\""));
}

TEST_CASE("unknown flags and subcommands are named") {
  UsageError flag = usageError({"camera", "--fovy", "40"});
  CHECK(flag.argument() == "--fovy");
  CHECK(contains(flag.what(), "unknown option --fovy"));
  CHECK(usageError({"camera", "-x"}).argument() == "-x");
  CHECK(usageError({"--verbose", "health"}).argument() == "--verbose");
  UsageError sub = usageError({"teleport"});
  CHECK(sub.argument() == "teleport");
  CHECK(contains(sub.what(), "unknown subcommand"));
  UsageError group = usageError({"lights"});
  CHECK(group.argument() == "lights");
  CHECK(group.what() == std::string("\"lights\" needs a subcommand: list, show, pick, add, set, "
                                    "rm, clear, generate"));
  UsageError groupBad = usageError({"lights", "explode"});
  CHECK(groupBad.argument() == "explode");
  CHECK(contains(groupBad.what(), "unknown subcommand \"lights explode\"; lights takes: list"));
  CHECK(usageError({"session", "--fov", "3"}).argument() == "session");
  CHECK(usageError({}).what() == std::string("no subcommand given"));
}

TEST_CASE("missing values name the option and what it takes") {
  UsageError e = usageError({"camera", "--eye"});
  CHECK(e.argument() == "--eye");
  CHECK(contains(e.what(), "needs a value (x,y,z)"));
  CHECK(usageError({"frame", "-o"}).argument() == "-o");
  CHECK(usageError({"settings", "--technique"}).argument() == "--technique");
  CHECK(contains(usageError({"settings", "--technique"}).what(), "volumes|tiled|clustered"));
  CHECK(usageError({"health", "--server"}).argument() == "--server");
  CHECK(usageError({"--session-file"}).argument() == "--session-file");
}

TEST_CASE("options given twice, flags with values, stray arguments") {
  CHECK(contains(usageError({"camera", "--fov", "40", "--fov", "50"}).what(), "more than once"));
  CHECK(usageError({"load", "--builtin=yes"}).argument() == "--builtin");
  UsageError stray = usageError({"health", "now"});
  CHECK(stray.argument() == "now");
  CHECK(contains(stray.what(), "unexpected argument"));
}

TEST_CASE("global options before or after the command") {
  Invocation a = parse({"--server", "http://h:1", "--json", "info"});
  CHECK(a.global.server == "http://h:1");
  CHECK(a.global.json);
  Invocation b = parse({"info", "--server=http://h:2", "--session-file", "/tmp/s"});
  CHECK(b.global.server == "http://h:2");
  CHECK(b.global.sessionFile == "/tmp/s");
  CHECK_FALSE(b.global.json);
}

TEST_CASE("help: overview, per command, and help wins over missing arguments") {
  Invocation overview = parse({"--help"});
  CHECK(overview.help);
  CHECK(overview.command == nullptr);
  Invocation lightsAdd = parse({"lights", "add", "-h"});
  CHECK(lightsAdd.help);
  CHECK(lightsAdd.command->name == "lights add");  // no --position needed for help
  CHECK(parse({"lights", "--help"}).help);
  CHECK(contains(commandHelp(*findCommand("camera")), "(from 1 to 179 degrees)"));
  CHECK(contains(commandHelp(*findCommand("frame")), "JPEG quality (from 1 to 100)"));
  CHECK(contains(commandHelp(*findCommand("frame")), "(from 0 to 1000000 seconds)"));
  CHECK(parse({"--version"}).version);
  CHECK(parse({"lights", "list", "--version"}).version);
  CHECK(contains(overviewHelp(), "--version"));
  // `myriad help COMMAND` is `myriad COMMAND --help`, for one- and two-word commands.
  Invocation helpLightsAdd = parse({"help", "lights", "add"});
  CHECK(helpLightsAdd.help);
  REQUIRE(helpLightsAdd.command != nullptr);
  CHECK(helpLightsAdd.command->name == "lights add");
  CHECK(parse({"help", "frame"}).command->name == "frame");
  CHECK(parse({"help", "lights", "pick"}).command->name == "lights pick");
  Invocation helpOnly = parse({"help"});
  CHECK(helpOnly.help);
  CHECK(helpOnly.command == nullptr);
  CHECK(parse({"help", "lights"}).command == nullptr);  // a group: the overview lists its commands
  CHECK(contains(usageError({"help", "nonsense"}).what(), "unknown command \"nonsense\""));
  CHECK(contains(commandHelp(*findCommand("session share")), "--ttl SECONDS"));
  CHECK(contains(commandHelp(*findCommand("lights pick")), "usage: myriad lights pick X Y"));
  CHECK(contains(overviewHelp(), "myriad help COMMAND"));
}

TEST_CASE("settings: colours, switches, choices, ranges") {
  Invocation inv = parse({"settings", "--sun-dir", "0,-1,0", "--sun-color", "1,0.9,0.8",
                          "--sun-intensity", "3", "--ambient", "0.1,0.1,0.1", "--exposure", "1.5",
                          "--markers", "off", "--technique", "tiled", "--animate", "on"});
  CHECK(inv.get<Vec3>("sun-dir") == Vec3{0, -1, 0});
  CHECK(inv.get<bool>("markers") == false);
  CHECK(inv.get<bool>("animate") == true);
  CHECK(inv.get<std::string>("technique") == "tiled");
  CHECK(inv.get<double>("exposure") == 1.5);

  CHECK(contains(usageError({"settings", "--technique", "forward"}).what(),
                 "is not one of volumes, tiled, clustered"));
  CHECK(usageError({"settings", "--markers", "maybe"}).argument() == "--markers");
  CHECK(usageError({"settings", "--exposure", "0"}).argument() == "--exposure");
  CHECK(parse({"settings", "--exposure", "1000"}).get<double>("exposure") == 1000.0);
  CHECK(usageError({"settings", "--exposure", "1000.5"}).argument() == "--exposure");
  CHECK(usageError({"settings", "--sun-color", "1,65,1"}).argument() == "--sun-color");
  CHECK(usageError({"settings", "--sun-dir", "0,0,0"}).argument() == "--sun-dir");
  CHECK(usageError({"settings", "--sun-intensity", "-1"}).argument() == "--sun-intensity");
}

TEST_CASE("material: ID and unit-interval members") {
  Invocation inv = parse({"material", "3", "--base-color", "1,0,0", "--metallic", "1",
                          "--roughness", "0"});
  CHECK(std::get<uint64_t>(inv.positionals.at(0)) == 3);
  CHECK(inv.get<Vec3>("base-color") == Vec3{1, 0, 0});
  CHECK(usageError({"material"}).argument() == "ID");
  CHECK(usageError({"material", "-3"}).argument() == "-3");  // not a whole number: an option
  CHECK(usageError({"material", "x"}).argument() == "ID");
  CHECK(usageError({"material", "1", "--base-color", "1.5,0,0"}).argument() == "--base-color");
  CHECK(usageError({"material", "1", "--roughness", "1.01"}).argument() == "--roughness");
  CHECK(usageError({"material", "1", "2"}).argument() == "2");
}

TEST_CASE("lights: add needs position and radius; generate takes ranges") {
  Invocation add = parse({"lights", "add", "--position", "1,2,3", "--radius", "4", "--color",
                          "1,0.5,0", "--intensity", "10", "--falloff", "2"});
  CHECK(add.command->name == "lights add");
  CHECK(add.get<double>("radius") == 4.0);
  UsageError noRadius = usageError({"lights", "add", "--position", "1,2,3"});
  CHECK(noRadius.argument() == "--radius");
  CHECK(contains(noRadius.what(), "needs --radius"));
  CHECK(usageError({"lights", "add", "--position", "1,2,3", "--radius", "0"}).argument() ==
        "--radius");
  CHECK(usageError({"lights", "add", "--position", "0,0,0", "--radius", "1", "--color",
                    "2,2,2"}).argument() == "--color");

  CHECK(usageError({"lights", "set", "7"}).argument() == "lights set");
  CHECK(parse({"lights", "set", "7", "--intensity", "0"}).get<double>("intensity") == 0.0);

  Invocation gen = parse({"lights", "generate", "1000", "--seed", "7", "--radius", "0.5,2",
                          "--intensity", "1,5", "--keep"});
  CHECK(std::get<uint64_t>(gen.positionals.at(0)) == 1000);
  CHECK(gen.get<uint64_t>("seed") == 7);
  CHECK(gen.get<Interval>("radius").min == 0.5);
  CHECK(gen.get<Interval>("radius").max == 2.0);
  CHECK(gen.has("keep"));
  CHECK(usageError({"lights", "generate", "0"}).argument() == "N");
  CHECK(usageError({"lights", "generate"}).argument() == "N");
  CHECK(contains(usageError({"lights", "generate", "5", "--radius", "2,1"}).what(),
                 "above max"));
  CHECK(usageError({"lights", "generate", "5", "--radius", "0,1"}).argument() == "--radius");
  CHECK(usageError({"lights", "generate", "5", "--radius", "1"}).argument() == "--radius");
  CHECK(parse({"lights", "generate", "5", "--seed", "9007199254740991"}).get<uint64_t>("seed") ==
        9007199254740991ull);
  CHECK(usageError({"lights", "generate", "5", "--seed", "9007199254740993"}).argument() ==
        "--seed");
  CHECK(usageError({"lights", "generate", "5", "--seed", "99999999999999999999999"}).argument() ==
        "--seed");

  CHECK(parse({"lights", "list", "--limit", "1000"}).get<uint64_t>("limit") == 1000);
  CHECK(usageError({"lights", "list", "--limit", "1001"}).argument() == "--limit");
  CHECK(parse({"lights", "list", "--limit", "0"}).get<uint64_t>("limit") == 0);
  CHECK(usageError({"lights", "rm"}).argument() == "ID");
}

TEST_CASE("load: exactly one source") {
  CHECK(std::get<std::string>(parse({"load", "model.glb"}).positionals.at(0)) == "model.glb");
  CHECK(parse({"load", "--library", "helmet.glb"}).get<std::string>("library") == "helmet.glb");
  CHECK(parse({"load", "--builtin"}).has("builtin"));
  CHECK(parse({"load", "--", "-odd-name.obj"}).positionals.size() == 1);
  CHECK(usageError({"load"}).argument() == "load");
  CHECK(contains(usageError({"load", "a.glb", "--builtin"}).what(), "only one of"));
}

TEST_CASE("asset add: a file, library:NAME or builtin:default; --entry only with a .zip") {
  Invocation file = parse({"asset", "add", "models/spider.obj"});
  REQUIRE(file.command != nullptr);
  CHECK(file.command->name == "asset add");
  CHECK(std::get<std::string>(file.positionals.at(0)) == "models/spider.obj");
  CHECK(std::get<std::string>(parse({"asset", "add", "library:helmet.glb"}).positionals.at(0)) ==
        "library:helmet.glb");
  CHECK(std::get<std::string>(parse({"asset", "add", "builtin:default"}).positionals.at(0)) ==
        "builtin:default");
  CHECK(parse({"asset", "add", "m.zip", "--entry", "a/b.gltf"}).get<std::string>("entry") ==
        "a/b.gltf");

  UsageError none = usageError({"asset", "add"});
  CHECK(none.argument() == "SOURCE");
  CHECK(none.command() == "asset add");
  CHECK(contains(none.what(), "\"asset add\" needs SOURCE"));
  UsageError entry = usageError({"asset", "add", "m.obj", "--entry", "x.obj"});
  CHECK(entry.argument() == "--entry");
  CHECK(contains(entry.what(), "inside a SOURCE.zip"));
  CHECK(usageError({"asset", "add", "library:"}).argument() == "SOURCE");
  UsageError builtin = usageError({"asset", "add", "builtin:cube"});
  CHECK(builtin.argument() == "SOURCE");
  CHECK(contains(builtin.what(), "the only built-in model is builtin:default"));
  CHECK(usageError({"asset", "add", "a.obj", "b.obj"}).argument() == "b.obj");
  CHECK(usageError({"asset", "add", "a.obj", "--at", "1,2,3"}).argument() == "--at");
}

TEST_CASE("asset show and delete take an asset id") {
  const char* id = "a-0123456789abcdef";
  CHECK(std::get<std::string>(parse({"asset", "show", id}).positionals.at(0)) == id);
  CHECK(parse({"asset", "delete", id}).command->name == "asset delete");
  CHECK(parse({"asset", "list"}).command->name == "asset list");
  for (const char* bad : {"a-0123", "0123456789abcdef", "a-0123456789ABCDEF",
                          "a-0123456789abcdefa", "a-0123456789abcdeg", "3"}) {
    INFO(bad);
    UsageError e = usageError({"asset", "show", bad});
    CHECK(e.argument() == "AID");
    CHECK(e.command() == "asset show");
    CHECK(contains(e.what(), "is not an asset id (a- and 16 hex digits"));
    CHECK(usageError({"asset", "delete", bad}).argument() == "AID");
  }
  CHECK(usageError({"asset", "delete"}).argument() == "AID");
  UsageError group = usageError({"asset"});
  CHECK(group.what() == std::string("\"asset\" needs a subcommand: add, list, show, delete"));
  CHECK(contains(usageError({"asset", "rm", id}).what(), "unknown subcommand \"asset rm\""));
}

TEST_CASE("object add: asset, name, transform, parent, semantic, hidden") {
  Invocation add = parse({"object", "add", "a-0123456789abcdef", "--name", "spider 1", "--at",
                          "1,-2,3.5", "--rotate", "0,0.7071,0,0.7071", "--scale", "2",
                          "--parent", "4", "--semantic", "65535", "--hidden", "--material", "0"});
  REQUIRE(add.command != nullptr);
  CHECK(add.command->name == "object add");
  CHECK(std::get<std::string>(add.positionals.at(0)) == "a-0123456789abcdef");
  CHECK(add.get<std::string>("name") == "spider 1");
  CHECK(add.get<Vec3>("at") == Vec3{1, -2, 3.5});
  CHECK(add.get<Vec4>("rotate") == Vec4{0, 0.7071, 0, 0.7071});
  CHECK(add.get<Vec3>("scale") == Vec3{2, 2, 2});  // one factor: every axis
  CHECK(add.get<uint64_t>("parent") == 4);
  CHECK(add.get<uint64_t>("semantic") == 65535);
  CHECK(add.get<uint64_t>("material") == 0);
  CHECK(add.has("hidden"));
  CHECK(parse({"object", "add", "a-0123456789abcdef", "--scale", "1,2,-3"}).get<Vec3>("scale") ==
        Vec3{1, 2, -3});
  Invocation bare = parse({"object", "add", "a-0123456789abcdef"});
  CHECK(bare.options.empty());

  CHECK(usageError({"object", "add"}).argument() == "ASSET");
  CHECK(usageError({"object", "add", "spider.obj"}).argument() == "ASSET");
  const char* a = "a-0123456789abcdef";
  UsageError rotate3 = usageError({"object", "add", a, "--rotate", "0,1,0"});
  CHECK(rotate3.argument() == "--rotate");
  CHECK(contains(rotate3.what(), "expected a quaternion of four numbers x,y,z,w"));
  UsageError rotate0 = usageError({"object", "add", a, "--rotate", "0,0,0,0"});
  CHECK(contains(rotate0.what(), "0,0,0,0 is no rotation"));
  CHECK(usageError({"object", "add", a, "--rotate", "0,0,0,nan"}).argument() == "--rotate");
  UsageError scale2 = usageError({"object", "add", a, "--scale", "1,2"});
  CHECK(scale2.argument() == "--scale");
  CHECK(contains(scale2.what(), "expected one number s or three x,y,z"));
  CHECK(usageError({"object", "add", a, "--scale", "2e6"}).argument() == "--scale");
  CHECK(usageError({"object", "add", a, "--at", "0,1e7,0"}).argument() == "--at");
  CHECK(usageError({"object", "add", a, "--parent", "0"}).argument() == "--parent");
  CHECK(usageError({"object", "add", a, "--parent", "4294967295"}).argument() == "--parent");
  CHECK(contains(usageError({"object", "add", a, "--semantic", "65536"}).what(),
                 "from 0 to 65535"));
  // A class name instead of a number: sent as the string.
  CHECK(parse({"object", "add", a, "--semantic", "car"}).get<std::string>("semantic") == "car");
  const std::string longName(65, 'x');
  CHECK(usageError({"object", "add", a, "--semantic", longName.c_str()}).argument() ==
        "--semantic");
  CHECK(usageError({"object", "add", a, "--hidden=yes"}).argument() == "--hidden");
  CHECK(usageError({"object", "add", a, "--visible", "false"}).argument() == "--visible");
}

TEST_CASE("object list, show, move, set, delete") {
  CHECK(parse({"object", "list", "--offset", "5", "--limit", "1000"}).get<uint64_t>("limit") ==
        1000);
  CHECK(usageError({"object", "list", "--limit", "1001"}).argument() == "--limit");
  CHECK(std::get<uint64_t>(parse({"object", "show", "7"}).positionals.at(0)) == 7);
  CHECK(usageError({"object", "show", "0"}).argument() == "OID");
  CHECK(usageError({"object", "show", "x"}).argument() == "OID");
  CHECK(usageError({"object", "delete"}).argument() == "OID");
  CHECK(std::get<uint64_t>(parse({"object", "delete", "4294967294"}).positionals.at(0)) ==
        4294967294ull);

  Invocation move = parse({"object", "move", "3", "--at", "0,1,0"});
  CHECK(move.command->name == "object move");
  CHECK(move.get<Vec3>("at") == Vec3{0, 1, 0});
  CHECK_FALSE(move.has("scale"));
  CHECK(parse({"object", "move", "3", "--reset"}).has("reset"));
  UsageError moveNothing = usageError({"object", "move", "3"});
  CHECK(moveNothing.argument() == "object move");
  CHECK(contains(moveNothing.what(), "needs at least one of --at, --rotate, --scale, --reset"));
  CHECK(usageError({"object", "move", "3", "--visible", "true"}).argument() == "--visible");

  Invocation set = parse({"object", "set", "3", "--visible", "false", "--parent", "none",
                          "--material", "12", "--name", "n", "--semantic", "2"});
  CHECK(set.get<bool>("visible") == false);
  CHECK(set.get<std::optional<uint64_t>>("parent") == std::nullopt);
  CHECK(set.get<std::optional<uint64_t>>("material") == std::optional<uint64_t>(12));
  CHECK(parse({"object", "set", "3", "--visible", "true"}).get<bool>("visible"));
  CHECK(parse({"object", "set", "3", "--parent", "9"}).get<std::optional<uint64_t>>("parent") ==
        std::optional<uint64_t>(9));
  CHECK(parse({"object", "set", "3", "--material", "none"})
            .get<std::optional<uint64_t>>("material") == std::nullopt);
  UsageError setNothing = usageError({"object", "set", "3"});
  CHECK(setNothing.argument() == "object set");
  CHECK(contains(setNothing.what(), "needs at least one of --visible"));
  CHECK(usageError({"object", "set", "3", "--visible", "maybe"}).argument() == "--visible");
  CHECK(usageError({"object", "set", "3", "--parent", "0"}).argument() == "--parent");
  UsageError parentWord = usageError({"object", "set", "3", "--parent", "world"});
  CHECK(parentWord.argument() == "--parent");
  CHECK(contains(parentWord.what(), "expected a whole number >= 0 or none"));
  CHECK(usageError({"object", "set", "3", "--asset", "spider"}).argument() == "--asset");
  CHECK(usageError({"object", "set", "3", "--at", "1,2,3"}).argument() == "--at");

  UsageError group = usageError({"object"});
  CHECK(group.what() ==
        std::string("\"object\" needs a subcommand: add, list, show, move, set, delete"));
}

TEST_CASE("asset and object help") {
  std::string add = commandHelp(*findCommand("object add"));
  CHECK(add.starts_with("usage: myriad object add ASSET [--name NAME] [--at x,y,z] "
                        "[--rotate x,y,z,w] [--scale s|x,y,z] [--parent OID]"));
  CHECK(contains(add, "(from 1 to 4294967294)"));
  CHECK(contains(add, "(from 0 to 65535)"));
  std::string set = commandHelp(*findCommand("object set"));
  CHECK(contains(set, "--visible true|false"));
  CHECK(contains(set, "--parent OID|none"));
  CHECK(contains(set, "--material MID|none"));
  CHECK(contains(commandHelp(*findCommand("asset add")),
                 "usage: myriad asset add SOURCE [--entry PATH]"));
  CHECK(contains(commandHelp(*findCommand("asset delete")), "Refused (409)"));
  CHECK(contains(overviewHelp(), "  asset add SOURCE "));
  CHECK(contains(overviewHelp(), "  object move OID "));
  CHECK(parse({"help", "object", "move"}).command->name == "object move");
  CHECK(parse({"object", "add", "--help"}).help);  // no ASSET needed for help
}

TEST_CASE("frame and stream: output required, formats, sizes, quality, fps") {
  Invocation frame = parse({"frame", "--target", "normal", "--format", "raw", "--width", "64",
                            "--height", "48", "-o", "-"});
  CHECK(frame.get<std::string>("output") == "-");
  CHECK(frame.get<std::string>("format") == "raw");
  CHECK(frame.get<uint64_t>("width") == 64);
  UsageError noOutput = usageError({"frame"});
  CHECK(noOutput.argument() == "-o");
  CHECK(usageError({"frame", "-o", "x", "--format", "gif"}).argument() == "--format");
  CHECK(usageError({"frame", "-o", "x", "--width", "0"}).argument() == "--width");
  CHECK(usageError({"frame", "-o", "x", "--width", "-5"}).argument() == "--width");
  CHECK(usageError({"frame", "-o", "x", "--width", "1.5"}).argument() == "--width");
  CHECK(usageError({"frame", "-o", "x", "--quality", "101"}).argument() == "--quality");

  Invocation stream = parse({"stream", "--fps", "60", "--frames", "3", "-o", "dir"});
  CHECK(stream.get<uint64_t>("fps") == 60);
  CHECK(stream.get<uint64_t>("frames") == 3);
  CHECK(usageError({"stream", "--fps", "61", "-o", "d"}).argument() == "--fps");
  CHECK(usageError({"stream", "--fps", "0", "-o", "d"}).argument() == "--fps");
  CHECK(usageError({"stream", "--frames", "0", "-o", "d"}).argument() == "--frames");
  CHECK(parse({"stream", "--format", "png", "-o", "d"}).get<std::string>("format") == "png");
  CHECK(usageError({"stream", "--format", "raw", "-o", "d"}).argument() == "--format");
}

TEST_CASE("value parsers on their own") {
  CHECK(parseNumber("-0.5", "x") == -0.5);
  CHECK(parseNumber("1e-3", "x") == 0.001);
  CHECK_THROWS_AS(parseNumber("1e999", "x"), UsageError);
  CHECK_THROWS_AS(parseNumber("12abc", "x"), UsageError);
  CHECK(parseUnsigned("18446744073709551615", "n") == 18446744073709551615ull);
  CHECK_THROWS_AS(parseUnsigned("18446744073709551616", "n"), UsageError);
  CHECK_THROWS_AS(parseUnsigned("+1", "n"), UsageError);
  CHECK(parseOnOff("true", "s"));
  CHECK_FALSE(parseOnOff("0", "s"));
  CHECK(parseRange("-1,1", "r").min == -1.0);
  CHECK(parseRotation("0,0,0,1", "q") == Vec4{0, 0, 0, 1});
  CHECK_THROWS_AS(parseRotation("0,0,1", "q"), UsageError);
  CHECK_THROWS_AS(parseRotation("0,0,0,0", "q"), UsageError);
  CHECK(parseScale("0.5", "s") == Vec3{0.5, 0.5, 0.5});
  CHECK(parseScale("1,2,3", "s") == Vec3{1, 2, 3});
  CHECK_THROWS_AS(parseScale("1,2,3,4", "s"), UsageError);
  CHECK_THROWS_AS(parseScale("", "s"), UsageError);
  CHECK(parseIdOrNone("none", "p") == std::nullopt);
  CHECK(parseIdOrNone("0", "p") == std::optional<uint64_t>(0));
  CHECK_THROWS_AS(parseIdOrNone("None", "p"), UsageError);
  CHECK_THROWS_AS(parseIdOrNone("-1", "p"), UsageError);
  CHECK_THROWS_AS(parseRange("1,2,3", "r"), UsageError);
}
