// The model library (--models DIR): what it lists, and which names resolve.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "loader/library.h"
#include "loader/loader.h"

namespace fs = std::filesystem;
using namespace myriad;

TEST_CASE("library: lists models and resolves only names inside the root") {
  const fs::path base = fs::temp_directory_path() / ("myriad-library-" + std::to_string(::getpid()));
  fs::remove_all(base);
  const fs::path root = base / "models";
  fs::create_directories(root / "sub" / "deeper");
  fs::create_directories(root / ".git");
  fs::create_directories(base / "outside");
  auto write = [](const fs::path& path, const std::string& text) { std::ofstream(path) << text; };
  const std::string triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  write(root / "a.obj", triangle);
  write(root / "sub" / "b.OBJ", triangle);
  write(root / "sub" / "deeper" / "c.obj", triangle);
  write(root / ".hidden.obj", triangle);
  write(root / ".git" / "d.obj", triangle);
  write(root / "notes.txt", "not a model");
  write(base / "outside" / "secret.obj", triangle);
  fs::create_symlink(base / "outside" / "secret.obj", root / "escape.obj");
  fs::create_directory_symlink(base / "outside", root / "escape-dir");
  fs::create_symlink(root / "a.obj", root / "sub" / "alias.obj");  // inside: allowed
  fs::create_directories(root / "dir.obj");                        // not a regular file

  const loader::ModelLibrary library(root);
  std::vector<std::string> names;
  for (const auto& entry : library.list()) names.push_back(entry.name);
  CHECK(names == std::vector<std::string>{"a.obj", "sub/alias.obj", "sub/b.OBJ", "sub/deeper/c.obj"});
  CHECK(library.list()[0].bytes == triangle.size());

  CHECK(library.resolve("a.obj") == fs::canonical(root / "a.obj"));
  CHECK(library.resolve("sub/deeper/c.obj").has_value());
  CHECK(library.resolve("sub/alias.obj") == fs::canonical(root / "a.obj"));
  const std::string absoluteOutside = (base / "outside" / "secret.obj").string();
  for (const std::string bad :
       {"", "../outside/secret.obj", "sub/../a.obj", "./a.obj", "/etc/passwd",
        absoluteOutside.c_str(), "escape.obj", "escape-dir/secret.obj",
        ".hidden.obj", ".git/d.obj", "notes.txt", "missing.obj", "dir.obj", "sub//b.OBJ",
        "sub\\b.OBJ", "a.obj/", "sub"}) {
    CAPTURE(bad);
    CHECK(!library.resolve(bad).has_value());
  }
  CHECK(!library.resolve(std::string_view("a.obj\0x", 7)).has_value());

  // What it resolves loads through the child.
  const scene::Scene scene = loader::loadModelFile(*library.resolve("sub/b.OBJ"));
  CHECK(scene.meshes.size() == 1);

  CHECK(loader::ModelLibrary({}).list().empty());
  CHECK(!loader::ModelLibrary({}).resolve("a.obj").has_value());
  CHECK_THROWS_AS(loader::ModelLibrary(base / "nope"), std::runtime_error);
  CHECK_THROWS_AS(loader::ModelLibrary(root / "a.obj"), std::runtime_error);
  fs::remove_all(base);
}

