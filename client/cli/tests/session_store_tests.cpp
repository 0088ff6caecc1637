// The session file: parsing, the default path, and writing it with mode 0600.
#include <doctest/doctest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "session_store.h"

using namespace myriad::cli;

TEST_CASE("id:token text") {
  auto parsed = parseSessionText("  s-0123456789abcdef:abcdef01\n");
  REQUIRE(parsed.has_value());
  CHECK(parsed->first == "s-0123456789abcdef");
  CHECK(parsed->second == "abcdef01");
  for (const char* bad : {"", "s-1", ":tok", "s-1:", "s 1:tok", "s/1:tok", "s-1:to:k"}) {
    INFO(bad);
    CHECK_FALSE(parseSessionText(bad).has_value());
  }
}

TEST_CASE("default path: XDG_STATE_HOME, else ~/.local/state") {
  CHECK(defaultSessionPath("/x/state", "/home/u") == "/x/state/myriad/session");
  CHECK(defaultSessionPath(nullptr, "/home/u") == "/home/u/.local/state/myriad/session");
  CHECK(defaultSessionPath("relative", "/home/u") == "/home/u/.local/state/myriad/session");
  CHECK_THROWS_AS(defaultSessionPath(nullptr, nullptr), std::runtime_error);
}

TEST_CASE("saved with mode 0600 in new 0700 directories, found, removed") {
  char pattern[] = "/tmp/myriad-cli-test-XXXXXX";
  REQUIRE(mkdtemp(pattern) != nullptr);
  std::filesystem::path root = pattern;
  std::string path = (root / "a" / "b" / "session").string();

  // A loose umask must not make the token readable by others.
  mode_t previous = umask(0);
  saveSession(path, "s-0123456789abcdef", "feedface");
  umask(previous);

  struct stat st{};
  REQUIRE(stat(path.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);
  REQUIRE(stat((root / "a").c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0700);
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  CHECK(text.str() == "s-0123456789abcdef:feedface\n");

  // An existing file with loose permissions is replaced by a 0600 one.
  chmod(path.c_str(), 0644);
  saveSession(path, "s-1", "t2");
  REQUIRE(stat(path.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);

  unsetenv("MYRIAD_SESSION");
  GlobalOptions global;
  global.sessionFile = path;
  SessionRef found = findSession(global);
  CHECK(found.id == "s-1");
  CHECK(found.token == "t2");
  CHECK(found.fromFile);
  CHECK(found.origin == path);

  // The environment wins over the file.
  setenv("MYRIAD_SESSION", "s-env:tok", 1);
  SessionRef fromEnv = findSession(global);
  CHECK(fromEnv.id == "s-env");
  CHECK_FALSE(fromEnv.fromFile);
  setenv("MYRIAD_SESSION", "garbage", 1);
  CHECK_THROWS_WITH_AS(findSession(global), "MYRIAD_SESSION is not of the form id:token",
                       std::runtime_error);
  unsetenv("MYRIAD_SESSION");

  CHECK(removeSessionFile(path));
  CHECK_FALSE(removeSessionFile(path));
  try {
    findSession(global);
    FAIL("found a session in a removed file");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("run `myriad session new` first") != std::string::npos);
  }
  std::filesystem::remove_all(root);
}
