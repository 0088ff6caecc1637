// What a frame request asks for and what a frame returns: the contract between the service and
// the renderer. Plain data; no Vulkan, no HTTP.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scene/scene.h"

namespace myriad::render {

// What the tonemap pass writes into the output image. Values match MYRIAD_VIEW_* in
// shaders/shared_types.h.
enum class Target : uint32_t {
  Final = 0,
  Albedo,
  Normal,
  Position,
  Uv,
  Metallic,
  Roughness,
  Depth,
  LightVolumes,
};

inline constexpr std::array<std::string_view, 9> kTargetNames = {
    "final", "albedo", "normal", "position", "uv", "metallic", "roughness", "depth",
    "light-volumes"};

inline std::string_view targetName(Target t) { return kTargetNames[static_cast<uint32_t>(t)]; }

inline std::optional<Target> parseTarget(std::string_view name) {
  for (uint32_t i = 0; i < kTargetNames.size(); ++i) {
    if (kTargetNames[i] == name) return static_cast<Target>(i);
  }
  return std::nullopt;
}

struct FrameSettings {
  uint32_t width = 1280;
  uint32_t height = 720;
  scene::Camera camera;
  Target target = Target::Final;
  bool markers = true;
  float exposure = 1.0f;
};

struct PassTiming {
  std::string name;     // e.g. "gbuffer", "sun", "lights", "markers", "tonemap", "readback"
  double milliseconds;  // GPU time from timestamp queries
};

// One rendered frame: tightly packed RGBA8 rows, top row first. The colour channels of `final` and
// `albedo` are sRGB-encoded; data views (normal, uv, depth...) hold their values directly.
struct Frame {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;
  std::vector<PassTiming> passes;
};

}  // namespace myriad::render
