// The server's routes against the protocol's operation table (protocol/operations.cpp), without
// HTTP: the check HttpServer::bind runs before it listens, and the query parameters the frame
// routes take.
#include <doctest/doctest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "protocol/constants.h"
#include "protocol/operations.h"
#include "service/api.h"
#include "service/frame_query.h"

namespace protocol = myriad::protocol;
namespace service = myriad::service;

namespace {

std::vector<service::RouteKey> tableRoutes() {
  std::vector<service::RouteKey> keys;
  for (const protocol::Operation& op : protocol::operations()) {
    keys.push_back({std::string(op.method), std::string(op.route)});
  }
  return keys;
}

template <typename Names>
std::set<std::string_view> setOf(const Names& names) {
  return {names.begin(), names.end()};
}

}  // namespace

TEST_CASE("routeTableMismatch: the table itself matches, in any order") {
  std::vector<service::RouteKey> keys = tableRoutes();
  CHECK(routeTableMismatch(keys) == "");
  std::reverse(keys.begin(), keys.end());
  CHECK(routeTableMismatch(keys) == "");
}

TEST_CASE("routeTableMismatch names a missing, an extra and a repeated route") {
  std::vector<service::RouteKey> keys = tableRoutes();
  keys.erase(std::find_if(keys.begin(), keys.end(), [](const service::RouteKey& k) {
    return k.method == "PATCH" && k.routeTemplate == protocol::routes::kSessionCamera;
  }));
  const std::string missing = routeTableMismatch(keys);
  CHECK(missing ==
        "the server has no route for PATCH /v1/sessions/{id}/camera of protocol/operations.cpp");

  keys = tableRoutes();
  keys.push_back({"POST", "/v1/sessions/{id}/snapshot"});
  keys.push_back({"DELETE", std::string(protocol::routes::kHealth)});
  const std::string extra = routeTableMismatch(keys);
  CHECK(extra.find("the server answers ") == 0);
  CHECK(extra.find("POST /v1/sessions/{id}/snapshot") != std::string::npos);
  CHECK(extra.find("DELETE /v1/health") != std::string::npos);
  CHECK(extra.find("which protocol/operations.cpp does not list") != std::string::npos);

  keys = tableRoutes();
  keys.push_back({"GET", std::string(protocol::routes::kInfo)});
  CHECK(routeTableMismatch(keys) == "registered twice: GET /v1/info");
}

TEST_CASE("the frame routes take the query parameters the protocol lists") {
  auto tableNames = [](std::string_view route) {
    const protocol::Operation* op = protocol::findOperation("GET", route);
    REQUIRE(op != nullptr);
    return setOf(protocol::queryParameterNames(*op));
  };
  CHECK(setOf(service::kFrameParameters) == tableNames(protocol::routes::kFrame));
  CHECK(setOf(service::kSessionFrameParameters) == tableNames(protocol::routes::kSessionFrame));
  CHECK(setOf(service::kStreamParameters) == tableNames(protocol::routes::kSessionStream));
}
