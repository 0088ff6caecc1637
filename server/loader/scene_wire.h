// The scene as bytes on the loader child's stdout. Versioned and little-endian (the child is this
// same executable, so both ends agree on the layout, but the parent still trusts nothing in it):
//
//   "MYRW" u32 version u32 meshes u32 materials u32 instances u32 lights u32 images u64 bodyBytes
//   body: sun (7 f32), ambient (3), background (3), camera (12)
//         materials: u32 nameBytes, name, baseColor (3 f32), metallic, roughness, alpha,
//                    emissive (3), emissiveStrength, normalScale, occlusionStrength,
//                    u8 alphaMode, f32 alphaCutoff, u8 doubleSided, u8 unlit, f32 ior,
//                    f32 specular, f32 clearcoat, f32 clearcoatRoughness, sheenColor (3 f32),
//                    f32 sheenRoughness, then 5 textures (baseColor,
//                    metallicRoughness, normal, occlusion, emissive): u32 image (~0 = none),
//                    u8 wrapS, wrapT, magFilter, minFilter, mipmaps, mipmapFilter,
//                    offset (2 f32), scale (2), rotation, u32 texCoord
//         meshes:    u32 nameBytes, name, u32 vertices, u32 indices, vertices (16 f32 each:
//                    position, normal, uv, tangent, color), indices
//         instances: u32 mesh, u32 material, transform (16 f32, column-major)
//         lights:    position (3 f32), radius, color (3), intensity, falloff, u32 type,
//                    u32 attenuation, direction (3 f32), innerConeAngle, outerConeAngle
//         u32 extra suns, each direction (3 f32), color (3), intensity; u32 dropped suns;
//         u32 ignored glTF extensions, each u32 nameBytes, name
//         u32 cameras, each u32 nameBytes, name, u32 perspective, yfov, aspectRatio, znear, zfar,
//                    position (3 f32), direction (3), up (3)
//         images:    u32 nameBytes, name, u32 width, u32 height, u32 bytes, RGBA8 pixels
//         u32 nodes, each u32 nameBytes, name, i32 parent, translation (3 f32),
//                    rotation (4: x y z w), scale (3)
//         per instance: i32 node, i32 skin
//         u32 skins, each u32 nameBytes, name, u32 joints, per joint u32 node, inverse bind (16
//         f32) per mesh:  u32 skinned, if 1 per vertex 4 u32 joints, 4 f32 weights; u32 morph
//                    targets, each u32 nameBytes, name, u8 attributes (1 positions, 2 normals,
//                    4 tangents), per attribute one vec3 (3 f32) per vertex, f32 default weight
//         u32 animations, each u32 nameBytes, name, f32 duration, u32 channels, each u32 node,
//                    u8 path, u8 interpolation, u32 keys, times (f32), u32 values, values (f32)
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include "scene/scene.h"

namespace myriad::loader {

// 2: lights' type, attenuation, cone; 3: materials' textures, images; 4: nodes, skins, morph
// targets, animations; 5: materials' unlit flag, ior and specular factor, ignored glTF extensions;
// 6: materials' clearcoat and sheen factors
inline constexpr uint32_t kSceneWireVersion = 6;

// The bytes were not a scene this version of the server wrote: what() says what was wrong.
struct SceneWireError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string encodeScene(const scene::Scene& scene);

// Checks everything before trusting it: counts against the bytes present (nothing is reserved
// from a count alone), every index in range, every float finite, factors in their ranges, names
// at most kMaxWireNameBytes, images within scene::ImageLimits and every texture's image index in range (invalid UTF-8 and control characters in names are replaced, since
// names go into JSON), and nothing left over at the end. Throws SceneWireError.
scene::Scene decodeScene(std::string_view bytes);

inline constexpr uint32_t kMaxWireNameBytes = 256;

// `text` with every byte sequence that is not UTF-8 replaced by '?' and control characters by
// spaces: what names and messages from the child become before they reach JSON or a log line.
std::string cleanText(std::string_view text);

}  // namespace myriad::loader
