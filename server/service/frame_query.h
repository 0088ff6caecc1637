// GET /v1/frame's query string -> render::FrameSettings, with every rule a client can break
// reported as the offending parameter and a sentence. Pure: no HTTP, no Vulkan.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::service {

inline constexpr std::array<std::string_view, 9> kFrameParameters = {
    "target", "width", "height", "eye", "look_at", "fov", "markers", "exposure", "technique"};

// What a frame request starts from before its parameters apply.
struct FrameDefaults {
  scene::Camera camera;       // the scene's default view
  scene::Bounds sceneBounds;  // to keep the scene inside the far plane from any eye
  uint32_t maxResolution = 4096;
  render::Technique technique = render::Technique::Clustered;  // --technique
};

class FrameQueryError : public std::runtime_error {
 public:
  FrameQueryError(std::string parameter, std::string detail, bool unknownParameter = false)
      : std::runtime_error(detail),
        parameter_(std::move(parameter)),
        unknownParameter_(unknownParameter) {}
  const std::string& parameter() const { return parameter_; }
  // True when the parameter itself is not one of kFrameParameters (rather than a bad value).
  bool unknownParameter() const { return unknownParameter_; }

 private:
  std::string parameter_;
  bool unknownParameter_;
};

// `params` is the decoded query (the same type as httplib::Params). Throws FrameQueryError for
// the first problem found: unknown or repeated parameters first, then values in the order of
// kFrameParameters.
render::FrameSettings parseFrameQuery(const std::multimap<std::string, std::string>& params,
                                      const FrameDefaults& defaults);

// The Server-Timing header value: one metric per GPU pass, then the CPU PNG encode, durations in
// milliseconds ("gbuffer;dur=1.234, sun;dur=0.5, encode;dur=3.1").
// With `culling` (tiled and clustered frames), a last entry without a duration carries the light
// lists' report, so that an overflow is visible in every browser's network panel:
// culling;desc="dropped 0 light references (tiles overflowed 0), list entries 5123 / ...".
std::string formatServerTiming(const std::vector<render::PassTiming>& passes, double encodeMs,
                               const render::CullingReport* culling = nullptr);

// One line for logs and headers: what light culling did this frame.
std::string describeCulling(const render::CullingReport& culling);

}  // namespace myriad::service
