// The asset and object commands against a small in-process cpp-httplib server (no renderer): the
// requests they send (routes, content types, bodies, the transform `object move` merges) and
// what they print for people and under --json.
#include <doctest/doctest.h>
#include <httplib.h>
#include <stdlib.h>
#include <unistd.h>

#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "commands.h"

using namespace myriad::cli;
using nlohmann::json;

namespace {

const char* kSessionId = "s-0123456789abcdef";
const char* kAssetId = "a-00112233445566ff";

struct Seen {
  std::string method, path, contentType, body;
  std::multimap<std::string, std::string> params;
};

// The requests a FakeServer's handlers saw (each handler records its request before answering, so
// a request is recorded once the client has its answer).
class Recorder {
 public:
  void add(const httplib::Request& req) {
    std::lock_guard<std::mutex> lock(mutex_);
    seen_.push_back({req.method, req.path, req.get_header_value("Content-Type"), req.body,
                     {req.params.begin(), req.params.end()}});
  }
  std::vector<Seen> seen() {
    std::lock_guard<std::mutex> lock(mutex_);
    return seen_;
  }

 private:
  std::mutex mutex_;
  std::vector<Seen> seen_;
};

// An httplib server on a free loopback port, serving on its own thread while in scope.
class FakeServer {
 public:
  explicit FakeServer(const std::function<void(httplib::Server&, Recorder&)>& routes) {
    routes(server_, recorder_);
    port_ = server_.bind_to_any_port("127.0.0.1");
    REQUIRE(port_ > 0);
    thread_ = std::thread([this] { server_.listen_after_bind(); });
  }
  ~FakeServer() {
    server_.stop();
    thread_.join();
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  std::vector<Seen> seen() { return recorder_.seen(); }

 private:
  Recorder recorder_;
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
};

struct Run {
  int status = -1;
  std::string out, err;
};

// `myriad ARGS` against `server` with MYRIAD_SESSION set; errors propagate as they would to main.
Run cli(FakeServer& server, std::vector<std::string> args) {
  setenv("MYRIAD_SESSION", (std::string(kSessionId) + ":tok").c_str(), 1);
  args.insert(args.begin(), {"--server", server.url()});
  Invocation inv = parseArguments(args);
  HttpClient http(parseServerUrl(*inv.global.server, "--server"));
  std::ostringstream out, err;
  Context ctx(inv, http, out, err);
  Run run;
  run.status = runCommand(ctx);
  run.out = out.str();
  run.err = err.str();
  return run;
}

json asset(uint64_t objects) {
  return {{"id", kAssetId},         {"source", "upload:spider.obj"}, {"bytes", 2048},
          {"meshes", 1},            {"instances", 1},
          {"materials", {{"first", 0}, {"count", 2}}},
          {"images", 0},            {"objects", objects},
          {"bounds", {{"min", {-1, 0, -1}}, {"max", {1, 2, 1}}}}};
}

json object(uint64_t id, const json& transform) {
  return {{"id", id},          {"name", "upload:spider.obj"}, {"asset", kAssetId},
          {"transform", transform}, {"visible", true}, {"parent", nullptr},
          {"material", nullptr}, {"semantic", 0}, {"instances", 1}};
}

const std::string kSessionPath = std::string("/v1/sessions/") + kSessionId;

}  // namespace

TEST_CASE("asset add uploads a file or names a source; 201 added, 200 already there") {
  int answers = 0;
  FakeServer server([&](httplib::Server& s, Recorder& rec) {
    s.Post(kSessionPath + "/assets", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.status = answers++ == 0 ? 201 : 200;
      res.set_content(asset(0).dump(), "application/json");
    });
  });
  char dir[] = "/tmp/myriad-cli-command-XXXXXX";
  REQUIRE(mkdtemp(dir) != nullptr);
  const std::string file = std::string(dir) + "/spider.obj";
  std::ofstream(file) << "v 0 0 0\n";

  Run added = cli(server, {"asset", "add", file});
  CHECK(added.status == 0);
  CHECK(added.out == std::string("added asset ") + kAssetId +
                         " (upload:spider.obj: 1 meshes, 1 instances, 2 materials (ids 0-1), 0 "
                         "images)\n");
  Run again = cli(server, {"asset", "add", file});
  CHECK(again.out.starts_with(std::string("asset ") + kAssetId + " was already in the session ("));
  Run library = cli(server, {"asset", "add", "library:helmet.glb"});
  CHECK(library.status == 0);
  Run raw = cli(server, {"asset", "add", "builtin:default", "--json"});
  CHECK(json::parse(raw.out) == asset(0));

  std::vector<Seen> seen = server.seen();
  REQUIRE(seen.size() == 4);
  CHECK(seen[0].method == "POST");
  CHECK(seen[0].contentType == "application/octet-stream");
  CHECK(seen[0].body == "v 0 0 0\n");
  CHECK(seen[0].params.find("filename")->second == "spider.obj");
  CHECK(seen[2].contentType == "application/json");
  CHECK(json::parse(seen[2].body) == json{{"source", "library:helmet.glb"}});
  CHECK(seen[2].params.empty());
  CHECK(json::parse(seen[3].body) == json{{"source", "builtin:default"}});

  // A missing file is said before anything is sent.
  CHECK_THROWS_WITH(cli(server, {"asset", "add", std::string(dir) + "/nope.obj"}),
                    ("cannot read " + std::string(dir) + "/nope.obj").c_str());
  CHECK(server.seen().size() == 4);
  unlink(file.c_str());
  rmdir(dir);
}

TEST_CASE("asset list, show, and a delete refused while used") {
  FakeServer server([&](httplib::Server& s, Recorder& rec) {
    s.Get(kSessionPath + "/assets", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.set_content(json{{"assets", {asset(1)}}}.dump(), "application/json");
    });
    s.Get(kSessionPath + "/assets/" + kAssetId, [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.set_content(asset(1).dump(), "application/json");
    });
    s.Delete(kSessionPath + "/assets/" + kAssetId, [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.status = 409;
      res.set_content(R"({"type":"https://myriad.dev/problems/conflict","title":"Conflict",)"
                      R"("status":409,"detail":"Asset \"a-00112233445566ff\" is in use: object 1 )"
                      R"(draws it (1 objects use it). Delete them first."})",
                      "application/problem+json");
    });
  });
  Run list = cli(server, {"asset", "list"});
  CHECK(list.out ==
        "ID                  SOURCE             MESHES  INSTANCES  MATERIAL IDS  IMAGES  OBJECTS  SIZE\n"
        "a-00112233445566ff  upload:spider.obj  1       1          0-1           0       1        2.0 KiB\n");
  Run show = cli(server, {"asset", "show", kAssetId});
  CHECK(show.out.find("materials  2 (session ids 0-1)\n") != std::string::npos);
  CHECK(show.out.find("bounds     min -1, 0, -1  max 1, 2, 1\n") != std::string::npos);
  CHECK(show.out.find("objects    1 use it (delete them to delete it)\n") != std::string::npos);
  try {
    cli(server, {"asset", "delete", kAssetId});
    FAIL("no error");
  } catch (const ApiError& e) {
    CHECK(e.status() == 409);
    CHECK(std::string(e.what()) == "Asset \"a-00112233445566ff\" is in use: object 1 draws it (1 "
                                   "objects use it). Delete them first. (409 conflict)");
  }
}

TEST_CASE("object add sends one object-new; list pages like lights list") {
  FakeServer server([&](httplib::Server& s, Recorder& rec) {
    s.Post(kSessionPath + "/objects", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.status = 201;
      res.set_content(R"({"ids":[5],"total":5})", "application/json");
    });
    s.Get(kSessionPath + "/objects", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      json moved = object(5, {{"translation", {1, 2, 3}}, {"rotation", {0, 0, 0, 1}},
                              {"scale", {2, 2, 2}}});
      json matrix = object(6, {{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 7, 8, 9, 1}}});
      matrix["parent"] = 5;
      res.set_content(json{{"total", 9}, {"offset", 4}, {"nextObjectId", 10},
                           {"objects", {moved, matrix}}}.dump(),
                      "application/json");
    });
  });
  Run added = cli(server, {"object", "add", kAssetId, "--at", "1,2,3", "--scale", "2",
                              "--hidden", "--parent", "4", "--name", "left", "--semantic", "3"});
  CHECK(added.out == "added object 5 (5 objects)\n");
  Run bare = cli(server, {"object", "add", kAssetId});
  std::vector<Seen> seen = server.seen();
  REQUIRE(seen.size() == 2);
  CHECK(json::parse(seen[0].body) ==
        json{{"objects",
              {{{"asset", kAssetId},
                {"name", "left"},
                {"transform",
                 {{"translation", {1, 2, 3}}, {"rotation", {0, 0, 0, 1}}, {"scale", {2, 2, 2}}}},
                {"visible", false},
                {"parent", 4},
                {"semantic", 3}}}}});
  CHECK(json::parse(seen[1].body) == json{{"objects", {{{"asset", kAssetId}}}}});

  Run list = cli(server, {"object", "list", "--offset", "4", "--limit", "2"});
  CHECK(list.out ==
        "ID  NAME               ASSET               AT       SCALE   VISIBLE  PARENT  INSTANCES\n"
        "5   upload:spider.obj  a-00112233445566ff  1, 2, 3  2       yes      -       1\n"
        "6   upload:spider.obj  a-00112233445566ff  7, 8, 9  matrix  yes      5       1\n"
        "2 of 9 objects; more with --offset 6\n");
  seen = server.seen();
  CHECK(seen.back().params.find("offset")->second == "4");
  CHECK(seen.back().params.find("limit")->second == "2");
}

TEST_CASE("object move keeps the members not given; set sends null for none") {
  json current = object(5, {{"translation", {1, 2, 3}}, {"rotation", {0, 1, 0, 0}},
                            {"scale", {2, 2, 2}}});
  FakeServer server([&](httplib::Server& s, Recorder& rec) {
    s.Get(kSessionPath + "/objects/5", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.set_content(current.dump(), "application/json");
    });
    s.Get(kSessionPath + "/objects/6", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.set_content(object(6, {{"matrix", {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 7, 8, 9, 1}}})
                          .dump(),
                      "application/json");
    });
    s.Patch(R"(/v1/sessions/[^/]+/objects/(\d+))",
            [&](const httplib::Request& req, httplib::Response& res) {
              rec.add(req);
              json patched = object(std::stoul(req.matches[1]), current["transform"]);
              json patch = json::parse(req.body);
              for (auto& [key, value] : patch.items()) patched[key] = value;
              res.set_content(patched.dump(), "application/json");
            });
  });
  Run moved = cli(server, {"object", "move", "5", "--at", "9,9,9"});
  CHECK(moved.out.find("translation  9, 9, 9\n") != std::string::npos);
  CHECK(moved.out.find("rotation     0, 1, 0, 0 (x, y, z, w)\n") != std::string::npos);
  CHECK(moved.out.find("scale        2, 2, 2\n") != std::string::npos);
  CHECK(moved.err.empty());
  std::vector<Seen> seen = server.seen();
  REQUIRE(seen.size() == 2);
  CHECK(seen[0].method == "GET");
  CHECK(seen[1].method == "PATCH");
  CHECK(json::parse(seen[1].body) ==
        json{{"transform",
              {{"translation", {9, 9, 9}}, {"rotation", {0, 1, 0, 0}}, {"scale", {2, 2, 2}}}}});

  // --json prints only the PATCH's answer.
  Run raw = cli(server, {"object", "move", "5", "--scale", "1,2,3", "--json"});
  json rawObject = json::parse(raw.out);
  CHECK(rawObject["transform"]["scale"] == json({1, 2, 3}));
  CHECK(rawObject["transform"]["translation"] == json({1, 2, 3}));

  // --reset: no GET, the members not given are the identity's.
  const size_t before = server.seen().size();
  cli(server, {"object", "move", "5", "--reset", "--rotate", "0,0,1,0"});
  seen = server.seen();
  REQUIRE(seen.size() == before + 1);
  CHECK(json::parse(seen.back().body) ==
        json{{"transform",
              {{"translation", {0, 0, 0}}, {"rotation", {0, 0, 1, 0}}, {"scale", {1, 1, 1}}}}});

  // An object placed by a matrix: the identity's members, and a note.
  Run matrix = cli(server, {"object", "move", "6", "--at", "1,1,1"});
  CHECK(matrix.err == "myriad: note: object 6 was placed by a matrix; the members not given are "
                      "the identity's\n");
  CHECK(json::parse(server.seen().back().body)["transform"]["scale"] == json({1, 1, 1}));

  Run set = cli(server, {"object", "set", "5", "--parent", "none", "--material", "3",
                            "--visible", "false"});
  CHECK(json::parse(server.seen().back().body) ==
        json{{"parent", nullptr}, {"material", 3}, {"visible", false}});
  CHECK(set.out.find("visible      no\n") != std::string::npos);
  CHECK(set.out.find("material     3\n") != std::string::npos);
  CHECK(set.out.find("parent       none (the world)\n") != std::string::npos);
}

TEST_CASE("object show and delete") {
  FakeServer server([&](httplib::Server& s, Recorder& rec) {
    s.Get(kSessionPath + "/objects/5", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      json o = object(5, {{"translation", {0, 0, 0}}, {"rotation", {0, 0, 0, 1}},
                          {"scale", {1, 1, 1}}});
      o["bounds"] = {{"min", {-1, 0, -1}}, {"max", {1, 2, 1}}};
      res.set_content(o.dump(), "application/json");
    });
    s.Delete(kSessionPath + "/objects/5", [&](const httplib::Request& req, httplib::Response& res) {
      rec.add(req);
      res.status = 204;
    });
  });
  Run show = cli(server, {"object", "show", "5"});
  CHECK(show.out ==
        "object       5\n"
        "name         upload:spider.obj\n"
        "asset        a-00112233445566ff\n"
        "translation  0, 0, 0\n"
        "rotation     0, 0, 0, 1 (x, y, z, w)\n"
        "scale        1, 1, 1\n"
        "visible      yes\n"
        "parent       none (the world)\n"
        "material     the asset's own\n"
        "semantic     0\n"
        "instances    1\n"
        "bounds       min -1, 0, -1  max 1, 2, 1\n");
  Run deleted = cli(server, {"object", "delete", "5"});
  CHECK(deleted.out == "deleted object 5 (and its children, if any)\n");
  CHECK(server.seen().back().method == "DELETE");
}
