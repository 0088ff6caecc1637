// The `myriad` binary against the real myriad-server (validation layers on), driven as a user
// would drive it: a session in a temporary session file, a model upload, camera, 1000 lights,
// settings, a material, frames in three formats, a stream, errors, and the session's end. The
// server must report no validation message at the end.
#include <doctest/doctest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_process.h"
#include "zip_builder.h"
#include "encode/png.h"
#include "server_process.h"

using myriad::test::CliResult;
using myriad::test::runCli;
using myriad::test::ServerProcess;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const std::string kModel = std::string(MYRIAD_TEST_MODELS) + "/OBJ/spider.obj";

std::string readFile(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

// Width and height from a JPEG's frame header, after checking the markers from SOI through
// SOS and the EOI at the end; nullopt when it is not a well-formed baseline/progressive JPEG.
std::optional<std::pair<int, int>> jpegSize(const std::string& b) {
  auto at = [&](size_t i) { return static_cast<unsigned char>(b[i]); };
  if (b.size() < 4 || at(0) != 0xFF || at(1) != 0xD8) return std::nullopt;
  if (at(b.size() - 2) != 0xFF || at(b.size() - 1) != 0xD9) return std::nullopt;
  std::optional<std::pair<int, int>> size;
  size_t i = 2;
  while (i + 4 <= b.size()) {
    if (at(i) != 0xFF) return std::nullopt;
    unsigned marker = at(i + 1);
    if (marker == 0xFF) {
      ++i;
      continue;
    }
    size_t length = size_t(at(i + 2)) << 8 | at(i + 3);
    if (length < 2 || i + 2 + length > b.size()) return std::nullopt;
    bool frameHeader = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                       marker != 0xCC;
    if (frameHeader && length >= 7) {
      size = std::make_pair(int(at(i + 7)) << 8 | at(i + 8), int(at(i + 5)) << 8 | at(i + 6));
    }
    if (marker == 0xDA) return size;  // entropy-coded data follows
    i += 2 + length;
  }
  return std::nullopt;
}

// The error output is exactly one line: "myriad: ... (<status> <type>)".
void checkOneLineError(const CliResult& r, const std::string& ending) {
  INFO("stderr: ", r.err);
  CHECK(r.exitCode == 1);
  CHECK(r.err.starts_with("myriad: "));
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.ends_with(ending + "\n"));
}

// A loopback port nothing listens on (bound, then closed).
int closedPort() {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t length = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length);
  close(fd);
  return ntohs(addr.sin_port);
}

}  // namespace

TEST_CASE("myriad drives a real server from session new to session delete") {
  REQUIRE(fs::exists(kModel));
  ServerProcess server({});
  REQUIRE(server.start() == ServerProcess::Start::Listening);

  char pattern[] = "/tmp/myriad-cli-scenario-XXXXXX";
  REQUIRE(mkdtemp(pattern) != nullptr);
  const fs::path dir = pattern;
  const std::string sessionFile = (dir / "state" / "session").string();
  const std::map<std::string, std::string> env = {
      {"MYRIAD_SERVER", server.url()}, {"MYRIAD_SESSION", ""}, {"MYRIAD_API_KEY", ""}};
  auto myriad = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"--session-file", sessionFile});
    CliResult r = runCli(args, env);
    MESSAGE("myriad ", args[2], " ", args.size() > 3 ? args[3] : "", " -> exit ", r.exitCode,
            r.err.empty() ? "" : ", stderr: " + r.err);
    return r;
  };
  auto jsonOf = [](const CliResult& r) {
    INFO("stdout: ", r.out, " stderr: ", r.err);
    REQUIRE(r.exitCode == 0);
    return json::parse(r.out);
  };

  CliResult health = myriad({"health"});
  CHECK(health.exitCode == 0);
  CHECK(health.out == "ok\n");
  json info = jsonOf(myriad({"info", "--json"}));
  CHECK(info["validation"]["enabled"] == true);
  CliResult humanInfo = myriad({"info"});
  CHECK(humanInfo.out.starts_with("server "));
  CHECK(humanInfo.out.find("validation      on, 0 messages\n") != std::string::npos);
  CliResult models = myriad({"models"});
  CHECK(models.exitCode == 0);
  CHECK(models.out.starts_with("no models"));

  // A command that needs a session, before there is one.
  CliResult noSession = myriad({"camera"});
  checkOneLineError(noSession, "or set MYRIAD_SESSION");
  CHECK(noSession.err.find("run `myriad session new` first") != std::string::npos);

  // session new: id:token saved, mode 0600.
  CliResult created = myriad({"session", "new"});
  REQUIRE(created.exitCode == 0);
  CHECK(created.out.find("saved to " + sessionFile) != std::string::npos);
  struct stat st{};
  REQUIRE(stat(sessionFile.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);
  const std::string saved = readFile(sessionFile);
  std::smatch match;
  REQUIRE(std::regex_match(saved, match, std::regex("(s-[0-9a-f]{16}):([0-9a-f]{64})\n")));
  const std::string sessionId = match[1];
  CHECK(created.out.find(sessionId) != std::string::npos);

  // --print-env prints a second session's variable and leaves the file alone.
  CliResult printed = myriad({"session", "new", "--print-env"});
  REQUIRE(printed.exitCode == 0);
  CHECK(std::regex_match(printed.out,
                         std::regex("export MYRIAD_SESSION=s-[0-9a-f]{16}:[0-9a-f]{64}\n")));
  CHECK(readFile(sessionFile) == saved);

  json state = jsonOf(myriad({"session", "show", "--json"}));
  CHECK(state["id"] == sessionId);
  CHECK(state["model"]["source"] == "builtin:default");

  // Upload a model.
  CliResult loaded = myriad({"load", kModel});
  REQUIRE(loaded.exitCode == 0);
  CHECK(loaded.out.starts_with("loaded upload:spider.obj: "));
  CliResult humanState = myriad({"session", "show"});
  CHECK(humanState.exitCode == 0);
  CHECK(humanState.out.find("model      upload:spider.obj (") != std::string::npos);
  json afterLoad = jsonOf(myriad({"session", "show", "--json"}));
  CHECK(afterLoad["model"]["source"] == "upload:spider.obj");
  CHECK(afterLoad["model"]["meshes"].get<int>() > 0);

  // A file that is no model: the loader process refuses it, the session keeps its model.
  const fs::path garbage = dir / "garbage.glb";
  std::ofstream(garbage) << "glTF but not really";
  checkOneLineError(myriad({"load", garbage.string()}), "(422 model-rejected)");
  CHECK(jsonOf(myriad({"session", "show", "--json"}))["model"]["source"] == "upload:spider.obj");
  checkOneLineError(myriad({"load", (dir / "missing.obj").string()}), "missing.obj");

  // A .zip of the model with its .mtl and textures goes as an archive; --entry picks the model.
  const fs::path objDir = fs::path(kModel).parent_path();
  std::vector<myriad::test::ZipEntry> entries;
  for (const char* name : {"spider.obj", "spider.mtl", "SpiderTex.jpg", "drkwood2.jpg"}) {
    entries.push_back({std::string("spider/") + name, readFile(objDir / name)});
  }
  entries.push_back({"other/box.obj", readFile(objDir / "box.obj")});
  const fs::path zip = dir / "spider.zip";
  std::ofstream(zip, std::ios::binary) << myriad::test::makeZip(entries);
  CliResult ambiguous = myriad({"load", zip.string()});
  checkOneLineError(ambiguous, "(422 model-rejected)");
  CHECK(ambiguous.err.find("name one with the entry parameter") != std::string::npos);
  CliResult zipped = myriad({"load", zip.string(), "--entry", "spider/spider.obj"});
  REQUIRE(zipped.exitCode == 0);
  CHECK(zipped.out.starts_with("loaded upload:spider.zip: "));
  CHECK(myriad({"load", kModel, "--entry", "x.obj"}).exitCode == 2);
  REQUIRE(myriad({"load", kModel}).exitCode == 0);

  // Camera: patch some members, read them back.
  CliResult camera = myriad({"camera", "frame"});
  CHECK(camera.exitCode == 0);
  json framed = jsonOf(myriad({"camera", "--json"}));
  CliResult patched = myriad({"camera", "--fov", "50", "--near", "0.05"});
  CHECK(patched.exitCode == 0);
  CHECK(patched.out.find("fov     50 degrees") != std::string::npos);
  json cameraNow = jsonOf(myriad({"camera", "--json"}));
  CHECK(cameraNow["fovY"] == 50.0);
  CHECK(cameraNow["near"] == 0.05);
  CHECK(cameraNow["eye"] == framed["eye"]);  // untouched members kept

  // 1000 lights from seed 7, twice: the same lights.
  CliResult generated = myriad({"lights", "generate", "1000", "--seed", "7"});
  CHECK(generated.exitCode == 0);
  CHECK(generated.out.find("1000 lights in the session") != std::string::npos);
  json page = jsonOf(myriad({"lights", "list", "--limit", "5", "--json"}));
  CHECK(page["total"] == 1000);
  CHECK(page["lights"].size() == 5);
  CHECK(myriad({"lights", "generate", "1000", "--seed", "7"}).exitCode == 0);
  json again = jsonOf(myriad({"lights", "list", "--limit", "5", "--json"}));
  for (size_t i = 0; i < 5; ++i) CHECK(again["lights"][i]["position"] == page["lights"][i]["position"]);
  CliResult added = myriad({"lights", "add", "--position", "0,1,0", "--radius", "2"});
  CHECK(added.exitCode == 0);
  CHECK(added.out.find("(1001 lights)") != std::string::npos);

  CliResult listed = myriad({"lights", "list", "--limit", "2", "--offset", "1000"});
  CHECK(listed.exitCode == 0);
  CHECK(listed.out.starts_with("ID "));
  CHECK(listed.out.find(" POSITION ") != std::string::npos);
  // Ids only: the light's id in its row, the page described by counts.
  const json listedJson = jsonOf(myriad({"lights", "list", "--offset", "1000", "--json"}));
  const std::string lastId = std::to_string(listedJson["lights"][0]["id"].get<uint64_t>());
  CHECK(listed.out.find("\n" + lastId + " ") != std::string::npos);
  CHECK(listed.out.ends_with("1 of 1001 lights\n"));
  CliResult firstPage = myriad({"lights", "list", "--limit", "2"});
  CHECK(firstPage.out.ends_with("2 of 1001 lights; more with --offset 2\n"));
  // `lights show` takes what `lights list` prints in its ID column (so do set and rm, below).
  CliResult shownLight = myriad({"lights", "show", lastId});
  CHECK(shownLight.exitCode == 0);
  CHECK(shownLight.out.find(lastId) != std::string::npos);
  // The same light made an inverse-square spot, and back to a point light.
  CliResult spot = myriad({"lights", "set", lastId, "--spot", "0,-1,0", "--cone", "0.2,0.4",
                           "--attenuation", "inverse-square"});
  CHECK(spot.exitCode == 0);
  CHECK(spot.out.find("light " + lastId + ": spot towards 0, -1, 0, cone 0.2 to 0.4 rad, inverse-square\n") !=
        std::string::npos);
  const json spotJson = jsonOf(myriad({"lights", "show", lastId, "--json"}));
  CHECK(spotJson["type"] == "spot");
  CHECK(spotJson["outerConeAngle"] == 0.4);
  CHECK(myriad({"lights", "set", lastId, "--cone", "0.5,0.4"}).exitCode == 2);  // min > max: usage
  checkOneLineError(myriad({"lights", "set", lastId, "--cone", "0.4,0.4"}), "(400 invalid-body)");  // inner == outer: the server
  CHECK(jsonOf(myriad({"lights", "set", lastId, "--point", "--json"}))["type"] == "point");

  // lights pick: the server looks among every light; the id it prints is an id `lights show`
  // takes.
  const json pickJson = jsonOf(myriad({"lights", "pick", "160", "120", "--width", "320",
                                       "--height", "240", "--radius", "64", "--json"}));
  REQUIRE(pickJson.contains("light"));
  const std::string pickedId = std::to_string(pickJson["light"]["id"].get<uint64_t>());
  CliResult picked = myriad({"lights", "pick", "160", "120", "--width", "320", "--height", "240",
                             "--radius", "64"});
  CHECK(picked.exitCode == 0);
  CHECK(picked.out.find("light " + pickedId + ": its marker is ") != std::string::npos);
  CHECK(myriad({"lights", "show", pickedId}).out.find(pickedId) != std::string::npos);
  CHECK(myriad({"lights", "pick", "-1", "0"}).exitCode == 2);
  checkOneLineError(myriad({"lights", "pick", "400", "10", "--width", "320", "--height", "240"}),
                    "(400 invalid-parameter)");

  // open: the page's address for the session; session share: a view-only token and its link,
  // which reads but cannot change the session.
  CliResult opened = myriad({"open"});
  CHECK(opened.exitCode == 0);
  std::smatch openedParts;
  REQUIRE(std::regex_match(opened.out, openedParts,
                           std::regex(R"((http://[^/]+)/#session=(s-[0-9a-f]{16})&token=([0-9a-f]{64})\n)")));
  CHECK(openedParts[1] == server.url());
  CHECK(openedParts[2] == sessionId);
  CliResult shared = myriad({"session", "share", "--ttl", "120"});
  CHECK(shared.exitCode == 0);
  std::smatch sharedParts;
  REQUIRE(std::regex_search(shared.out, sharedParts,
                            std::regex("link +" + server.url() + "/#session=" + sessionId +
                                       "&token=([0-9a-f]{64})\n")));
  const std::string viewerToken = sharedParts[1];
  CHECK(viewerToken != openedParts[3].str());
  CHECK(std::regex_search(shared.out, std::regex("\nexpires +in 120 s\n")));
  std::map<std::string, std::string> viewerEnv = env;
  viewerEnv["MYRIAD_SESSION"] = sessionId + ":" + viewerToken;
  CliResult viewerShow = runCli({"session", "show"}, viewerEnv);
  CHECK(viewerShow.exitCode == 0);
  CHECK(std::regex_search(viewerShow.out, std::regex("^session +" + sessionId + "\n")));
  CliResult viewerEdit = runCli({"camera", "--fov", "30"}, viewerEnv);
  checkOneLineError(viewerEdit, "(403 forbidden)");
  CHECK(myriad({"session", "unshare"}).exitCode == 0);
  checkOneLineError(runCli({"session", "show"}, viewerEnv), "(401 unauthorized)");

  // Settings.
  CliResult tiled = myriad({"settings", "--technique", "tiled", "--exposure", "1.2"});
  CHECK(tiled.exitCode == 0);
  CHECK(tiled.out.find("technique      tiled\n") != std::string::npos);
  CHECK(tiled.out.find("exposure       1.2\n") != std::string::npos);
  json settings = jsonOf(myriad({"settings", "--json"}));
  CHECK(settings["technique"] == "tiled");
  CHECK(settings["exposure"] == 1.2);

  // A material.
  json materials = jsonOf(myriad({"materials", "--json"}));
  REQUIRE(materials["materials"].size() > 0);
  const std::string mid = std::to_string(materials["materials"][0]["id"].get<uint64_t>());
  json material = jsonOf(myriad({"material", mid, "--base-color", "0.8,0.2,0.1", "--roughness",
                                 "0.4", "--json"}));
  CHECK(material["baseColor"] == json::array({0.8, 0.2, 0.1}));
  CHECK(material["roughness"] == 0.4);
  CliResult shown = myriad({"material", mid});
  CHECK(shown.exitCode == 0);
  CHECK(shown.out.find("0.8, 0.2, 0.1") != std::string::npos);

  // A PNG of the normals: signature, size, and not one flat colour.
  const fs::path png = dir / "n.png";
  CliResult normal = myriad({"frame", "--target", "normal", "--width", "160", "--height", "120",
                             "-o", png.string()});
  REQUIRE(normal.exitCode == 0);
  std::string pngBytes = readFile(png);
  REQUIRE(pngBytes.size() > 8);
  CHECK(pngBytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
  auto image = myriad::encode::decodePng(
      {reinterpret_cast<const uint8_t*>(pngBytes.data()), pngBytes.size()});
  CHECK(image.width == 160);
  CHECK(image.height == 120);
  std::set<uint32_t> colours;
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    colours.insert(uint32_t(image.rgba[i]) | uint32_t(image.rgba[i + 1]) << 8 |
                   uint32_t(image.rgba[i + 2]) << 16);
  }
  CHECK(colours.size() > 20);

  // The same frame on standard output.
  CliResult toStdout = myriad({"frame", "--width", "64", "--height", "48", "-o", "-"});
  REQUIRE(toStdout.exitCode == 0);
  CHECK(toStdout.out.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);

  // Raw floats: the size follows from the channel list the CLI reports.
  const fs::path raw = dir / "f.raw";
  CliResult rawFrame = myriad({"frame", "--format", "raw", "--width", "32", "--height", "24",
                               "-o", raw.string()});
  REQUIRE(rawFrame.exitCode == 0);
  std::smatch channels;
  REQUIRE(std::regex_search(rawFrame.out, channels, std::regex("32x24 \\(channels ([a-z,]+)\\)")));
  const size_t channelCount = size_t(std::count(channels[1].first, channels[1].second, ',') + 1);
  std::string floats = readFile(raw);
  REQUIRE(floats.size() == 32 * 24 * channelCount * sizeof(float));
  size_t finite = 0;
  for (size_t i = 0; i < floats.size(); i += 4) {
    float v;
    std::memcpy(&v, floats.data() + i, 4);
    finite += std::isfinite(v) ? 1 : 0;
  }
  CHECK(finite == floats.size() / 4);
  json rawSummary = jsonOf(myriad({"frame", "--format", "raw", "--target", "depth", "--width",
                                   "16", "--height", "8", "-o", raw.string(), "--json"}));
  CHECK(rawSummary["width"] == 16);
  CHECK(rawSummary["height"] == 8);
  CHECK(rawSummary["channels"] == "depth");
  CHECK(rawSummary["target"] == "depth");
  CHECK(rawSummary["bytes"] == 16 * 8 * 4);
  CHECK(fs::file_size(raw) == 16 * 8 * 4);

  // A JPEG frame and three from the stream.
  const fs::path jpeg = dir / "f.jpg";
  REQUIRE(myriad({"frame", "--format", "jpeg", "--quality", "80", "--width", "80", "--height",
                  "60", "-o", jpeg.string()}).exitCode == 0);
  CHECK(jpegSize(readFile(jpeg)) == std::make_pair(80, 60));
  const fs::path frames = dir / "frames";
  CliResult streamed = myriad({"stream", "--frames", "3", "--fps", "30", "--width", "96",
                               "--height", "64", "-o", frames.string()});
  REQUIRE(streamed.exitCode == 0);
  CHECK(streamed.out.find("wrote 3 frames to") != std::string::npos);
  for (const char* name : {"frame-0000.jpg", "frame-0001.jpg", "frame-0002.jpg"}) {
    INFO(name);
    CHECK(jpegSize(readFile(frames / name)) == std::make_pair(96, 64));
  }
  CHECK_FALSE(fs::exists(frames / "frame-0003.jpg"));
  checkOneLineError(myriad({"stream", "--target", "nonsense", "--frames", "1", "-o",
                            (dir / "no-frames").string()}),
                    "(400 invalid-parameter)");
  CHECK_FALSE(fs::exists(dir / "no-frames"));

  json stats = jsonOf(myriad({"stats", "--json"}));
  CHECK(stats["frames"].get<int>() >= 4);
  CliResult humanStats = myriad({"stats"});
  CHECK(humanStats.out.find("last frame") != std::string::npos);
  CHECK(humanStats.out.find("gpu memory") != std::string::npos);

  // Errors: one line and exit 1 from the server; exit 2 with the argument named for usage.
  checkOneLineError(myriad({"material", "9999", "--roughness", "0.5"}), "(404 not-found)");
  checkOneLineError(myriad({"lights", "rm", "999999"}), "(404 not-found)");
  checkOneLineError(myriad({"camera", "--eye", "0,0,0", "--target", "0,0,0"}),
                    "(400 invalid-body)");
  checkOneLineError(myriad({"frame", "--target", "nonsense", "-o", (dir / "x.png").string()}),
                    "(400 invalid-parameter)");
  CHECK_FALSE(fs::exists(dir / "x.png"));
  CliResult usage = myriad({"camera", "--fov", "180"});
  CHECK(usage.exitCode == 2);
  CHECK(usage.err.starts_with("myriad: --fov: 180 is out of range"));
  CHECK(std::count(usage.err.begin(), usage.err.end(), '\n') == 1);

  // An unreachable server: one sentence, exit 1.
  CliResult refused = runCli({"health"}, {{"MYRIAD_SERVER", "http://127.0.0.1:" +
                                                                std::to_string(closedPort())}});
  CHECK(refused.exitCode == 1);
  CHECK(refused.err.find("cannot connect to a Myriad server at http://127.0.0.1:") !=
        std::string::npos);
  CHECK(std::count(refused.err.begin(), refused.err.end(), '\n') == 1);

  // One light edited, shown, removed; then all of them.
  const std::string lid = std::to_string(again["lights"][0]["id"].get<uint64_t>());
  json edited = jsonOf(myriad({"lights", "set", lid, "--intensity", "3.5", "--color", "1,0,0",
                               "--json"}));
  CHECK(edited["intensity"] == 3.5);
  CHECK(edited["color"] == json::array({1.0, 0.0, 0.0}));
  CHECK(jsonOf(myriad({"lights", "show", lid, "--json"})) == edited);
  CliResult removed = myriad({"lights", "rm", lid});
  CHECK(removed.out == "removed light " + lid + "\n");
  checkOneLineError(myriad({"lights", "show", lid}), "(404 not-found)");
  CHECK(jsonOf(myriad({"lights", "list", "--limit", "0", "--json"}))["total"] == 1000);
  CHECK(myriad({"lights", "clear"}).out == "removed every light\n");
  CHECK(jsonOf(myriad({"lights", "list", "--json"}))["total"] == 0);

  // session delete: gone on the server and from the file; the environment's copy now 404s.
  CliResult deleted = myriad({"session", "delete"});
  CHECK(deleted.exitCode == 0);
  CHECK_FALSE(fs::exists(sessionFile));
  auto stale = env;
  stale["MYRIAD_SESSION"] = saved.substr(0, saved.size() - 1);
  checkOneLineError(runCli({"session", "show"}, stale), "(404 not-found)");

  json infoAfter = jsonOf(myriad({"info", "--json"}));
  CHECK(infoAfter["validation"]["messages"] == 0);
  auto exit = server.stop();
  REQUIRE(exit.has_value());
  CHECK(exit->cleanExit());
  INFO("server stderr: ", server.stderrText().substr(0, 2000));
  fs::remove_all(dir);
}

TEST_CASE("session new with the server's API key: flag, environment, and the 401 without") {
  ServerProcess server({"--api-key", "sesame-0123", "--max-upload-bytes", "100000"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  char pattern[] = "/tmp/myriad-cli-key-XXXXXX";
  REQUIRE(mkdtemp(pattern) != nullptr);
  const fs::path dir = pattern;
  const std::string sessionFile = (dir / "session").string();
  std::map<std::string, std::string> env = {
      {"MYRIAD_SERVER", server.url()}, {"MYRIAD_SESSION", ""}, {"MYRIAD_API_KEY", ""}};

  CliResult refused = runCli({"--session-file", sessionFile, "session", "new"}, env);
  checkOneLineError(refused, "(401 unauthorized)");
  CHECK_FALSE(fs::exists(sessionFile));
  checkOneLineError(
      runCli({"--session-file", sessionFile, "session", "new", "--api-key", "wrong"}, env),
      "(401 unauthorized)");

  CliResult withFlag =
      runCli({"--session-file", sessionFile, "session", "new", "--api-key", "sesame-0123"}, env);
  CHECK(withFlag.exitCode == 0);
  CHECK(fs::exists(sessionFile));
  CHECK(withFlag.err.empty());
  // A second session new replaces the file and says which session it no longer points at.
  const std::string first = readFile(sessionFile).substr(0, 18);
  CliResult second =
      runCli({"--session-file", sessionFile, "session", "new", "--api-key", "sesame-0123"}, env);
  CHECK(second.exitCode == 0);
  CHECK(second.err.find("held session " + first + ", which stays open") != std::string::npos);
  CHECK(readFile(sessionFile).substr(0, 18) != first);
  // The key only creates sessions; the session's own token does the rest.
  CHECK(runCli({"--session-file", sessionFile, "session", "show"}, env).exitCode == 0);

  // An upload over --max-upload-bytes: the server may close the connection before reading it
  // all, so either its 413 or the CLI's own reading of the limit comes back, on one line.
  const fs::path big = dir / "big.glb";
  std::ofstream(big) << std::string(3 << 20, 'x');
  CliResult tooBig = runCli({"--session-file", sessionFile, "load", big.string()}, env);
  CHECK(tooBig.exitCode == 1);
  CHECK(std::count(tooBig.err.begin(), tooBig.err.end(), '\n') == 1);
  CHECK(tooBig.err.find("100000") != std::string::npos);
  INFO(tooBig.err);
  CHECK((tooBig.err.ends_with("(413 limit-exceeded)\n") ||
         tooBig.err.ends_with("more than this server accepts (maxUploadBytes 100000)\n")));
  CHECK(runCli({"--session-file", sessionFile, "session", "delete"}, env).exitCode == 0);

  env["MYRIAD_API_KEY"] = "sesame-0123";
  CliResult fromEnv = runCli({"session", "new", "--print-env"}, env);
  CHECK(fromEnv.exitCode == 0);
  CHECK(fromEnv.out.starts_with("export MYRIAD_SESSION=s-"));

  CHECK(json::parse(runCli({"info", "--json"}, env).out)["apiKeyRequired"] == true);
  auto exit = server.stop();
  REQUIRE(exit.has_value());
  CHECK(exit->cleanExit());
  fs::remove_all(dir);
}

TEST_CASE("assets and objects: add, place, move, a delete refused while used, clean up") {
  REQUIRE(fs::exists(kModel));
  ServerProcess server({});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  char pattern[] = "/tmp/myriad-cli-objects-XXXXXX";
  REQUIRE(mkdtemp(pattern) != nullptr);
  const fs::path dir = pattern;
  const std::string sessionFile = (dir / "session").string();
  const std::map<std::string, std::string> env = {
      {"MYRIAD_SERVER", server.url()}, {"MYRIAD_SESSION", ""}, {"MYRIAD_API_KEY", ""}};
  auto myriad = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"--session-file", sessionFile});
    CliResult r = runCli(args, env);
    MESSAGE("myriad ", args[2], " ", args.size() > 3 ? args[3] : "", " -> exit ", r.exitCode,
            r.err.empty() ? "" : ", stderr: " + r.err);
    return r;
  };
  auto jsonOf = [](const CliResult& r) {
    INFO("stdout: ", r.out, " stderr: ", r.err);
    REQUIRE(r.exitCode == 0);
    return json::parse(r.out);
  };
  REQUIRE(myriad({"session", "new"}).exitCode == 0);
  // The session's model (builtin:default) is one asset drawn by one object already.
  const json assetsBefore = jsonOf(myriad({"asset", "list", "--json"}));
  const size_t assetCount = assetsBefore["assets"].size();
  const uint64_t objectCount = jsonOf(myriad({"object", "list", "--json"}))["total"];

  // asset add: a new asset (201), then the same bytes again (200): the same id.
  CliResult added = myriad({"asset", "add", kModel});
  REQUIRE(added.exitCode == 0);
  std::smatch match;
  REQUIRE(std::regex_match(added.out, match,
                           std::regex("added asset (a-[0-9a-f]{16}) \\(upload:spider\\.obj: "
                                      "[1-9][0-9]* meshes, [1-9][0-9]* instances, .*\\)\n")));
  const std::string assetId = match[1];
  CliResult again = myriad({"asset", "add", kModel});
  CHECK(again.exitCode == 0);
  CHECK(again.out.starts_with("asset " + assetId + " was already in the session (upload:spider.obj: "));
  CliResult assetList = myriad({"asset", "list"});
  CHECK(assetList.out.starts_with("ID "));
  CHECK(std::regex_search(assetList.out, std::regex("\n" + assetId + " +upload:spider\\.obj +")));
  json asset = jsonOf(myriad({"asset", "show", assetId, "--json"}));
  CHECK(asset["id"] == assetId);
  CHECK(asset["source"] == "upload:spider.obj");
  CHECK(asset["objects"] == 0);
  CHECK(asset["bytes"] == fs::file_size(kModel));
  CHECK(jsonOf(myriad({"asset", "list", "--json"}))["assets"].size() == assetCount + 1);

  // object add with --at and --scale; list shows it with its translation and scale.
  CliResult placed = myriad({"object", "add", assetId, "--name", "spider", "--at", "1,2,3",
                             "--scale", "2"});
  REQUIRE(placed.exitCode == 0);
  REQUIRE(std::regex_match(placed.out, match, std::regex("added object ([0-9]+) \\(([0-9]+) objects\\)\n")));
  const std::string oid = match[1];
  CHECK(std::stoull(match[2]) == objectCount + 1);
  CliResult objects = myriad({"object", "list"});
  CHECK(objects.exitCode == 0);
  CHECK(objects.out.starts_with("ID "));
  CHECK(std::regex_search(objects.out, std::regex("\n" + oid + " +spider +" + assetId +
                                                  " +1, 2, 3 +2 +yes +- +[1-9][0-9]*\n")));
  CHECK(objects.out.ends_with(std::to_string(objectCount + 1) + " of " +
                              std::to_string(objectCount + 1) + " objects\n"));
  json shown = jsonOf(myriad({"object", "show", oid, "--json"}));
  CHECK(shown["asset"] == assetId);
  CHECK(shown["transform"]["translation"] == json::array({1.0, 2.0, 3.0}));
  CHECK(shown["transform"]["scale"] == json::array({2.0, 2.0, 2.0}));
  CHECK(shown["instances"].get<int>() > 0);
  REQUIRE(shown.contains("bounds"));
  CHECK(myriad({"asset", "show", assetId}).out.find("objects    1 use it") != std::string::npos);

  // object move: the translation changes, the scale given before stays; the bounds follow.
  CliResult moved = myriad({"object", "move", oid, "--at", "-4,0,5"});
  REQUIRE(moved.exitCode == 0);
  CHECK(moved.out.find("translation  -4, 0, 5\n") != std::string::npos);
  CHECK(moved.out.find("scale        2, 2, 2\n") != std::string::npos);
  json movedJson = jsonOf(myriad({"object", "show", oid, "--json"}));
  CHECK(movedJson["transform"]["translation"] == json::array({-4.0, 0.0, 5.0}));
  CHECK(movedJson["transform"]["scale"] == json::array({2.0, 2.0, 2.0}));
  for (int axis : {0, 1, 2}) {
    const double shift = std::array<double, 3>{-5.0, -2.0, 2.0}[axis];
    CHECK(movedJson["bounds"]["min"][axis].get<double>() ==
          doctest::Approx(shown["bounds"]["min"][axis].get<double>() + shift).epsilon(1e-4));
  }
  // --if-match: an edit conditional on a version the session is not at changes nothing (412).
  CliResult stale = myriad({"--if-match", "\"0-00000000\"", "object", "move", oid, "--at", "9,9,9"});
  checkOneLineError(stale, "(412 precondition-failed)");
  CHECK(jsonOf(myriad({"object", "show", oid, "--json"}))["transform"]["translation"] ==
        json::array({-4.0, 0.0, 5.0}));
  CHECK(myriad({"--if-match", "*", "object", "move", oid, "--at", "-4,0,5"}).exitCode == 0);

  const fs::path png = dir / "objects.png";
  CHECK(myriad({"frame", "--width", "64", "--height", "48", "-o", png.string()}).exitCode == 0);
  CHECK(fs::file_size(png) > 8);

  // The asset cannot go while the object draws it: the server's 409 detail, on one line.
  CliResult refused = myriad({"asset", "delete", assetId});
  checkOneLineError(refused, "(409 conflict)");
  CHECK(refused.err.find("is in use: object " + oid + " draws it") != std::string::npos);
  CHECK(refused.out.empty());
  CHECK(jsonOf(myriad({"asset", "list", "--json"}))["assets"].size() == assetCount + 1);

  // object set: hidden, it draws nothing.
  CliResult hidden = myriad({"object", "set", oid, "--visible", "false", "--semantic", "7"});
  CHECK(hidden.exitCode == 0);
  CHECK(hidden.out.find("visible      no\n") != std::string::npos);
  json hiddenJson = jsonOf(myriad({"object", "show", oid, "--json"}));
  CHECK(hiddenJson["visible"] == false);
  CHECK(hiddenJson["semantic"] == 7);
  // A class by name: the server keeps the name on the object and gives it an id for the labels.
  CliResult named = myriad({"object", "set", oid, "--semantic", "spider"});
  CHECK(named.exitCode == 0);
  CHECK(named.out.find("semantic     spider\n") != std::string::npos);
  CHECK(jsonOf(myriad({"object", "show", oid, "--json"}))["semantic"] == "spider");
  CHECK(myriad({"object", "set", oid, "--semantic", "7"}).exitCode == 0);
  CHECK(hiddenJson["instances"] == 0);

  // Usage mistakes are caught before a request: exit 2.
  CHECK(myriad({"object", "add", "spider.obj"}).exitCode == 2);
  CHECK(myriad({"object", "move", oid}).exitCode == 2);
  CHECK(myriad({"asset", "delete", "a-123"}).exitCode == 2);
  checkOneLineError(myriad({"object", "show", "999999"}), "(404 not-found)");

  // object delete, then the asset goes too.
  CliResult objectDeleted = myriad({"object", "delete", oid});
  CHECK(objectDeleted.exitCode == 0);
  CHECK(objectDeleted.out == "deleted object " + oid + " (and its children, if any)\n");
  checkOneLineError(myriad({"object", "show", oid}), "(404 not-found)");
  CHECK(jsonOf(myriad({"object", "list", "--json"}))["total"] == objectCount);
  CliResult assetDeleted = myriad({"asset", "delete", assetId});
  CHECK(assetDeleted.exitCode == 0);
  CHECK(assetDeleted.out == "deleted asset " + assetId + "\n");
  checkOneLineError(myriad({"asset", "show", assetId}), "(404 not-found)");
  CHECK(jsonOf(myriad({"asset", "list", "--json"})) == assetsBefore);

  CHECK(myriad({"session", "delete"}).exitCode == 0);
  CHECK(jsonOf(myriad({"info", "--json"}))["validation"]["messages"] == 0);
  auto exit = server.stop();
  REQUIRE(exit.has_value());
  CHECK(exit->cleanExit());
  fs::remove_all(dir);
}

TEST_CASE("clock: shown, paused at a time, played at a rate; out-of-range rates refused") {
  ServerProcess server({});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  char pattern[] = "/tmp/myriad-cli-clock-XXXXXX";
  REQUIRE(mkdtemp(pattern) != nullptr);
  const fs::path dir = pattern;
  const std::string sessionFile = (dir / "session").string();
  const std::map<std::string, std::string> env = {
      {"MYRIAD_SERVER", server.url()}, {"MYRIAD_SESSION", ""}, {"MYRIAD_API_KEY", ""}};
  auto myriad = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"--session-file", sessionFile});
    return runCli(args, env);
  };
  REQUIRE(myriad({"session", "new"}).exitCode == 0);
  CliResult shown = myriad({"clock"});
  REQUIRE(shown.exitCode == 0);
  CHECK(std::regex_search(shown.out, std::regex("^time +[0-9.e+-]+ s\nplaying +yes\nrate +1\n")));
  CliResult paused = myriad({"clock", "--play", "off", "--time", "1.5"});
  REQUIRE(paused.exitCode == 0);
  CHECK(paused.out.starts_with("time          1.5 s\nplaying       no\n"));
  const json clock = json::parse(myriad({"--json", "clock"}).out);
  CHECK(clock["time"] == 1.5);
  CHECK(clock["playing"] == false);
  CliResult fast = myriad({"clock", "--rate", "-2", "--play", "on"});
  REQUIRE(fast.exitCode == 0);
  CHECK(fast.out.find("rate          -2\n") != std::string::npos);
  CliResult bad = myriad({"clock", "--rate", "100"});
  CHECK(bad.exitCode == 2);
  CHECK(bad.err.find("--rate") != std::string::npos);
  fs::remove_all(dir);
}
