// The web client (client/web), embedded in the binary: the server answers GET / and
// GET /web/<file> from here, so it runs from any directory with nothing installed beside it.
#pragma once

#include <string_view>

namespace myriad::web {

struct Asset {
  std::string_view body;
  std::string_view contentType;  // with "; charset=utf-8" for text
};

// The asset for a request path: "/" (and "/web/", "/index.html") is index.html, "/web/<file>"
// is that file. nullptr for anything else, so "/web/../x" or a directory is a 404.
const Asset* findAsset(std::string_view path);

}  // namespace myriad::web
