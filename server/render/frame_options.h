// The named choices of a frame: targets, techniques, G-buffer paths, environment modes,
// anti-aliasing, local shadows, with their names (protocol/constants.h) and parsers; and the
// environment and shadow settings. Part of the contract between the service and the renderer
// (render/frame.h includes it). Plain data; no Vulkan, no HTTP.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/constants.h"

namespace myriad::render {

// What the final pass (or, for data views, the views pass) writes into the output image. Values index protocol::kTargets (the names)
// and equal MYRIAD_VIEW_* in shaders/shared_types.h (render/gpu_types.h checks both).
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
  LightCount,  // heat map of the lights that shade each pixel, with its scale drawn in
  Clusters,    // the clustered technique's depth slices, one colour each
  Emissive,    // emitted radiance (emissive factor x strength x texture)
  Occlusion,   // the material's ambient occlusion (1 where it has none)
  // Labels: per pixel, the nearest opaque or alpha-tested surface's object id (0: none), its
  // object's semantic class, its material id. Drawn by their own pass (recordLabelPass) against
  // the G-buffer's depth and always read back raw: FrameSettings::raw must be set, and
  // Frame::data then holds four uint32 bit patterns a pixel (object, semantic, material, 1 where
  // a surface is; all 0 elsewhere), to be read with std::bit_cast, never as floats.
  InstanceId,
  SemanticId,
  MaterialId,
  // Screen-space motion in pixels from the previous time (FrameSettings::previousCamera,
  // previousPose) to the frame's: a surface's pixel now minus its pixel then (x right, y down),
  // for camera, instance, skin and morph motion alike (render/motion.h). Raw: dx, dy, 1 where a
  // surface is (else all 0), 0; 8-bit: a false-colour picture. Drawn against the raster G-buffer.
  Motion,
  // The sun's shadow factor at each surface (1 lit, 0 in shadow) and the cascade of the sun's
  // map it came from (render/shadows.h): 8-bit, the factor tinted by cascade (0 red, 1 green,
  // 2 blue, 3 yellow), black where there is no surface or the sun casts none; raw: lit, cascade
  // (-1 where none). Read from the G-buffer by the views pass.
  Shadow,
};

// Whether `target` is one of the label targets (InstanceId, SemanticId, MaterialId).
inline bool isLabel(Target target) {
  return target == Target::InstanceId || target == Target::SemanticId ||
         target == Target::MaterialId;
}

// FrameSettings::alsoRead holds at most this many targets (a frame reads at most 8 with its own).
inline constexpr size_t kMaxExtraTargets = 7;

// The names are the protocol's, defined once there.
inline constexpr const auto& kTargetNames = protocol::kTargets;
static_assert(kTargetNames.size() == static_cast<size_t>(Target::Shadow) + 1);

inline std::string_view targetName(Target t) { return kTargetNames[static_cast<uint32_t>(t)]; }

inline std::optional<Target> parseTarget(std::string_view name) {
  for (uint32_t i = 0; i < kTargetNames.size(); ++i) {
    if (kTargetNames[i] == name) return static_cast<Target>(i);
  }
  return std::nullopt;
}

// How local lights are shaded. The same image whichever (tests hold them to 1/255 of each other);
// they differ in cost. A technique is an index into protocol::kTechniques, its name, and into
// render/techniques/registry.cpp, its implementation; there is no other list of them. The named
// values are the ones code refers to by name (defaults, tests); a new technique needs none.
enum class Technique : uint32_t {
  Volumes = 0,  // the seed's: one instanced draw of sphere proxies, additive blending
  Tiled,        // compute: 16x16-pixel tiles, lists in shared memory (Andersson 2011)
  Clustered,    // compute: tiles x depth slices, lists assigned on the GPU (Olsson et al. 2012)
};

inline constexpr const auto& kTechniqueNames = protocol::kTechniques;
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Volumes)] == protocol::techniques::kVolumes);
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Tiled)] == protocol::techniques::kTiled);
static_assert(kTechniqueNames[static_cast<size_t>(Technique::Clustered)] ==
              protocol::techniques::kClustered);

// Every technique, in order.
inline std::vector<Technique> allTechniques() {
  std::vector<Technique> all;
  for (uint32_t i = 0; i < kTechniqueNames.size(); ++i) all.push_back(static_cast<Technique>(i));
  return all;
}

// "volumes, tiled or clustered": the names as a sentence lists them (usage, error messages).
inline std::string techniqueChoices() {
  std::string text;
  for (size_t i = 0; i < kTechniqueNames.size(); ++i) {
    if (i > 0) text += i + 1 == kTechniqueNames.size() ? " or " : ", ";
    text += kTechniqueNames[i];
  }
  return text;
}

inline std::string_view techniqueName(Technique t) {
  return kTechniqueNames[static_cast<uint32_t>(t)];
}

inline std::optional<Technique> parseTechnique(std::string_view name) {
  for (uint32_t i = 0; i < kTechniqueNames.size(); ++i) {
    if (kTechniqueNames[i] == name) return static_cast<Technique>(i);
  }
  return std::nullopt;
}

// How a frame's G-buffer is made (myriad-server and myriad-bench --gbuffer; render/visibility.h).
// Raster: the graphics pipeline (vertex + fragment shaders), every scene, every device. Compute:
// triangles rasterised by compute shaders into 64-bit depth+id keys, then materials resolved per
// pixel into the same targets; used for frames whose scene qualifies (opaque, untextured
// materials) on devices with 64-bit buffer atomics, the raster path otherwise. Auto: compute
// where it qualifies on a GPU, raster on CPU implementations (lavapipe), where raster is cheaper.
// A frame's pass names say which ran: "gbuffer", or "visibility" and "resolve". myriad-server's
// default is Auto, myriad-bench's Raster (its tables compare against earlier runs).
enum class GBufferPath : uint32_t { Raster = 0, Compute, Auto };
inline constexpr std::array<std::string_view, 3> kGBufferPathNames = {"raster", "compute", "auto"};

inline std::string_view gbufferPathName(GBufferPath p) {
  return kGBufferPathNames[static_cast<uint32_t>(p)];
}

inline std::optional<GBufferPath> parseGBufferPath(std::string_view name) {
  for (uint32_t i = 0; i < kGBufferPathNames.size(); ++i) {
    if (kGBufferPathNames[i] == name) return static_cast<GBufferPath>(i);
  }
  return std::nullopt;
}

// The environment light (image-based lighting; render/environment.cpp, shaders/environment.glsl).
// Values index protocol::kEnvironmentModes and equal MYRIAD_ENV_* (render/gpu_types.h checks).
enum class EnvironmentMode : uint32_t {
  None = 0,  // the constant `ambient` term, exactly as before the environment existed
  Sky,       // the procedural sky, from the sun's direction and colour
  Hdr,       // the scene's equirectangular .hdr (Renderer::setEnvironmentImage)
};

inline std::string_view environmentModeName(EnvironmentMode m) {
  return protocol::kEnvironmentModes[static_cast<uint32_t>(m)];
}

inline std::optional<EnvironmentMode> parseEnvironmentMode(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kEnvironmentModes.size(); ++i) {
    if (protocol::kEnvironmentModes[i] == name) return static_cast<EnvironmentMode>(i);
  }
  return std::nullopt;
}

// Anti-aliasing of the `final` view (8-bit output only: raw values and data views are never
// filtered, jittered or supersampled). Values index protocol::kAntialiasModes; None and Fxaa
// equal MYRIAD_ANTIALIAS_* (gpu_types.h). Taa and Ssaa are made of sub-frames rendered with None
// and resolved on the host (render/sub_frames.h): the GPU passes never see them.
enum class Antialias : uint32_t {
  None = 0,  // the tonemapped image as it is
  Fxaa,      // luminance-edge detection and a directional blend after tonemapping (antialias.comp)
  Taa,       // 8 sub-frames jittered on a Halton (2,3) sequence, clamped and blended (sub_frames.h)
  Ssaa,      // rendered at 2x2 the size, box-downsampled in linear light (sub_frames.h)
};

inline std::string_view antialiasName(Antialias a) {
  return protocol::kAntialiasModes[static_cast<uint32_t>(a)];
}

inline std::optional<Antialias> parseAntialias(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kAntialiasModes.size(); ++i) {
    if (protocol::kAntialiasModes[i] == name) return static_cast<Antialias>(i);
  }
  return std::nullopt;
}

struct EnvironmentSettings {
  EnvironmentMode mode = EnvironmentMode::None;
  float intensity = 1.0f;   // scales the environment's light (and its background), >= 0
  float rotation = 0.0f;    // radians about +Y (hdr only: the sky's orientation is the sun's)
  bool background = false;  // show the environment where no geometry is (else `background`)
};

// How local lights cast shadows; the index into protocol::kLocalShadowModes.
enum class LocalShadows : uint32_t { None = 0, Maps, Stochastic };
static_assert(protocol::kLocalShadowModes.size() == 3);

inline std::string_view localShadowsName(LocalShadows m) {
  return protocol::kLocalShadowModes.at(static_cast<uint32_t>(m));
}

inline std::optional<LocalShadows> parseLocalShadows(std::string_view name) {
  for (uint32_t i = 0; i < protocol::kLocalShadowModes.size(); ++i) {
    if (protocol::kLocalShadowModes[i] == name) return static_cast<LocalShadows>(i);
  }
  return std::nullopt;
}

// Shadows (render/shadows.h). Off by default at this level, so frames and tests that do not ask
// for them stay as they were; sessions turn the sun's on for their scenes (service/session_scene).
struct ShadowSettings {
  bool sun = false;         // the sun casts shadows (cascades of maps, render/shadows.h)
  uint32_t mapSize = 2048;  // each of the sun's maps, texels across: kShadowMapSizes
  // The sun's cascades, 1..kMaxSunCascades: 1 is one map over the scene's bounds, fixed while
  // the camera moves; more split the view's depth, each map fitted to its part of the view.
  uint32_t cascades = 4;  // kDefaultSunCascades
  // The cascades move by whole texels (render/shadows.h). Only tests turn it off, to show the
  // shimmer it prevents; no request can.
  bool snapCascades = true;
  // Local lights asking for shadows (scene::PointLight::castsShadows) that get a map this frame,
  // at most: 0..MYRIAD_MAX_SHADOWED_LIGHTS (kMaxShadowedLights); the rest are unshadowed.
  uint32_t maxShadowedLights = 4;  // kDefaultShadowedLights
  // How local lights cast shadows (protocol::local_shadow_modes; render/stochastic_shadows.h):
  // None, Maps (the budgeted maps above, as before) or Stochastic (every light: a light sampled
  // per pixel from its cluster list, one shadow ray through the scene's BVH).
  LocalShadows local = LocalShadows::Maps;
};

// The most maxShadowedLights may be (shaders/shared_types.h MYRIAD_MAX_SHADOWED_LIGHTS; the
// schema's maximum, checked by the protocol test).
inline constexpr uint32_t kMaxShadowedLights = 16;
inline constexpr uint32_t kDefaultShadowedLights = 4;

// The sun's cascades at most, and by default (shaders/shared_types.h MYRIAD_MAX_SUN_CASCADES; the
// schema's sunCascades).
inline constexpr uint32_t kMaxSunCascades = 4;
inline constexpr uint32_t kDefaultSunCascades = 4;

// The sizes a shadow map may have (protocol/schemas/defs.schema.json's shadowMapSize).
inline constexpr std::array<uint32_t, 5> kShadowMapSizes = {256, 512, 1024, 2048, 4096};

}  // namespace myriad::render
