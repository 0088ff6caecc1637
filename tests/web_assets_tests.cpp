// The embedded web client: every file of client/web is served byte for byte with the type a
// browser needs (module scripts are refused unless served as JavaScript), and nothing else is.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "web_assets.h"

using myriad::web::findAsset;

namespace {

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

TEST_CASE("web assets: / is the page, /web/<file> each file, byte for byte") {
  const auto* index = findAsset("/");
  REQUIRE(index != nullptr);
  CHECK(index->contentType == "text/html; charset=utf-8");
  CHECK(index->body.starts_with("<!doctype html>"));
  CHECK(findAsset("/web/") == index);
  CHECK(findAsset("/index.html") == index);
  CHECK(findAsset("/web/index.html") == index);

  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(MYRIAD_WEB_DIR)) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".html" && ext != ".css" && ext != ".js") continue;
    const std::string name = entry.path().filename().string();
    CAPTURE(name);
    const auto* asset = findAsset("/web/" + name);
    REQUIRE(asset != nullptr);
    CHECK(asset->body == readFile(entry.path()));
    const char* type = ext == ".html" ? "text/html; charset=utf-8"
                       : ext == ".css" ? "text/css; charset=utf-8"
                                       : "text/javascript; charset=utf-8";
    CHECK(asset->contentType == type);
    ++files;
  }
  CHECK(files >= 10);  // the page, its style sheet and its modules
}

TEST_CASE("web assets: anything else is not found") {
  for (const char* path : {"", "/web", "/web/nope.js", "/main.js", "/web/../CMakeLists.txt",
                           "/web/CMakeLists.txt", "/web/web_assets.cpp", "/web//main.js",
                           "web/main.js", "/web/main.js?x=1", "/WEB/main.js"}) {
    CAPTURE(path);
    const auto* asset = findAsset(path);
    // "/web" alone is the page (a missing slash is forgiven); the rest are not assets.
    if (std::string_view(path) == "/web") {
      CHECK(asset == findAsset("/"));
    } else {
      CHECK(asset == nullptr);
    }
  }
}
