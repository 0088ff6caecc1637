#include "web_assets.h"

#include <string>
#include <unordered_map>

#include "myriad_web_files_files.h"

namespace myriad::web {
namespace {

std::string_view contentTypeFor(std::string_view name) {
  const size_t dot = name.rfind('.');
  const std::string_view ext = dot == std::string_view::npos ? "" : name.substr(dot + 1);
  // Modules must be served as JavaScript or the browser refuses them.
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "js") return "text/javascript; charset=utf-8";
  if (ext == "png") return "image/png";
  if (ext == "svg") return "image/svg+xml";
  return "application/octet-stream";
}

// Built once, on first use; read-only afterwards, so any thread may look up.
const std::unordered_map<std::string_view, Asset>& assets() {
  static const auto table = [] {
    std::unordered_map<std::string_view, Asset> map;
    for (const embedded::EmbeddedFile& file : embedded::embeddedFiles()) {
      map.emplace(file.name, Asset{file.bytes, contentTypeFor(file.name)});
    }
    return map;
  }();
  return table;
}

}  // namespace

const Asset* findAsset(std::string_view path) {
  std::string_view name;
  if (path == "/" || path == "/index.html" || path == "/web" || path == "/web/") {
    name = "index.html";
  } else if (path.starts_with("/web/")) {
    name = path.substr(5);
  } else {
    return nullptr;
  }
  // Exact names only: the table holds no "..", no directories, nothing outside client/web.
  const auto& table = assets();
  const auto it = table.find(name);
  return it == table.end() ? nullptr : &it->second;
}

}  // namespace myriad::web
