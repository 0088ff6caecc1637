// The frame and stream query parsers (server/service/frame_query.h) on a query string decoded as
// the server decodes it (httplib's parse_query_text: split at & and =, percent-decoding).
//
// Input: the first byte picks the route (GET /v1/frame, a session frame, a stream) and the
// maximum resolution; the rest is the query string after '?'.
// Promises checked: only FrameQueryError is thrown, and it names a parameter and a reason; an
// accepted request has a size within the maximum, a known target and format, a quality and fps
// in their ranges, and a finite camera with near < far.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include <httplib.h>

#include "fuzz_support.h"
#include "scene/builtin_scene.h"
#include "service/frame_query.h"

namespace service = myriad::service;
namespace render = myriad::render;
using myriad::fuzz::broken;
using myriad::fuzz::require;

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

void checkAccepted(const service::FrameRequest& request, uint32_t maxResolution) {
  const render::FrameSettings& s = request.settings;
  require(s.width >= 1 && s.width <= maxResolution, "width outside [1, max]");
  require(s.height >= 1 && s.height <= maxResolution, "height outside [1, max]");
  require(uint32_t(s.target) < render::kTargetNames.size(), "unknown target");
  require(uint32_t(s.technique) < render::kTechniqueNames.size(), "unknown technique");
  require(request.quality >= 1 && request.quality <= 100, "quality outside [1, 100]");
  require(request.fps >= 1 && request.fps <= service::kMaxStreamFps, "fps outside [1, max]");
  // What is read back raw: label targets whatever the format (render::Target::InstanceId);
  // every target for raw, png16 and exr; all but final's 8-bit picture for npy and npz.
  using F = service::ImageFormat;
  const bool floats = request.format == F::Raw || request.format == F::Npy ||
                      request.format == F::Npz || request.format == F::Exr;
  const bool rawExpected =
      render::isLabel(s.target) || request.format == F::Raw || request.format == F::Png16 ||
      request.format == F::Exr ||
      ((request.format == F::Npy || request.format == F::Npz) && s.target != render::Target::Final);
  require(s.raw == rawExpected, "raw and format disagree");
  require(!request.targets.empty(), "no target");
  const auto asked = [&](render::Target t) {
    for (render::Target x : request.targets) if (x == t) return true;
    return false;
  };
  require(asked(s.target), "settings.target is not one of the targets asked for");
  require(!request.depthDistance || (asked(render::Target::Depth) && floats),
          "depth=distance outside float depth");
  require(!request.cameraSpace ||
              ((asked(render::Target::Position) || asked(render::Target::Normal)) && floats),
          "space=camera outside float position or normal");
  require(!request.time || std::isfinite(*request.time), "time not finite");
  require(std::isfinite(s.exposure), "exposure not finite");
  const auto& c = s.camera;
  require(finite(c.eye) && finite(c.target) && finite(c.up), "camera not finite");
  require(std::isfinite(c.fovYDegrees) && c.fovYDegrees > 0 && c.fovYDegrees < 180, "fov out of range");
  require(std::isfinite(c.nearPlane) && std::isfinite(c.farPlane) && c.nearPlane > 0 &&
              c.nearPlane < c.farPlane,
          "near/far out of order");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const service::FrameDefaults defaults = [] {
    const auto scene = myriad::scene::makeBuiltinScene();
    service::FrameDefaults d;
    d.camera = scene.camera;
    d.sceneBounds = scene.bounds();
    return d;
  }();
  const uint8_t selector = data[0];
  // 16 px exercises the size checks at small numbers; 4096 is the server's default.
  const uint32_t maxResolution = (selector & 4) ? 16 : 4096;
  service::QueryParams params;
  httplib::detail::parse_query_text(std::string(reinterpret_cast<const char*>(data + 1), size - 1),
                                    params);
  try {
    switch (selector % 4) {
      case 0: {
        service::FrameDefaults d = defaults;
        d.maxResolution = maxResolution;
        checkAccepted(service::parseFrameRequest(params, d), maxResolution);
        break;
      }
      case 1:
        checkAccepted(service::parseSessionFrameQuery(params, maxResolution), maxResolution);
        break;
      case 2:
        checkAccepted(service::parseStreamQuery(params, maxResolution), maxResolution);
        break;
      default: {
        service::FrameDefaults d = defaults;
        d.maxResolution = maxResolution;
        render::FrameSettings settings = service::parseFrameQuery(params, d);
        require(settings.width >= 1 && settings.width <= maxResolution, "width outside [1, max]");
        break;
      }
    }
  } catch (const service::FrameQueryError& e) {
    require(!e.parameter().empty(), "a refusal that names no parameter");
    require(std::string_view(e.what()).size() > 0, "a refusal without a sentence");
  }
  return 0;
}
