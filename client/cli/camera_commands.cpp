// camera [--eye ...] (PATCH, or GET without options), camera frame.
#include "commands.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

void printCamera(std::ostream& out, const protocol::Camera& c) {
  printFields(out, {{"eye", formatVec(c.eye)},
                    {"target", formatVec(c.target)},
                    {"up", formatVec(c.up)},
                    {"fov", formatNumber(c.fovY) + " degrees"},
                    {"near", formatNumber(c.near)},
                    {"far", formatNumber(c.far)}});
}

}  // namespace

int runCameraCommand(Context& ctx) {
  const Invocation& inv = ctx.inv;
  nlohmann::json camera;
  if (inv.command->name == "camera frame") {
    camera = ctx.call("POST", ctx.sessionRoute(protocol::routes::kSessionCameraFrame));
  } else if (inv.options.empty()) {
    camera = ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionCamera));
  } else {
    protocol::CameraPatch patch;
    patch.eye = inv.find<Vec3>("eye");
    patch.target = inv.find<Vec3>("target");
    patch.up = inv.find<Vec3>("up");
    patch.fovY = inv.find<double>("fov");
    patch.near = inv.find<double>("near");
    patch.far = inv.find<double>("far");
    camera = ctx.call("PATCH", ctx.sessionRoute(protocol::routes::kSessionCamera), patch);
  }
  if (!ctx.json()) printCamera(ctx.out, camera.get<protocol::Camera>());
  return 0;
}

}  // namespace myriad::cli
