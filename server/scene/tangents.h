// MikkTSpace vertex tangents for meshes whose file gives none: glTF 2.0 says a client SHOULD
// compute them with MikkTSpace (Mikkelsen, "Simulation of wrinkled surfaces revisited", 2008),
// because normal maps are baked against that frame; the per-pixel derivative frame the G-buffer
// pass falls back to differs from it by degrees at fine detail.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace myriad::scene {

// Gives the vertices of the triangle list `indices` tangents as glTF's TANGENT (unit xyz along +u,
// w = +-1 with bitangent = w * cross(normal, tangent) pointing to -v), following MikkTSpace: a
// vertex is a (position, normal, uv) value; each triangle's tangent and bitangent directions come
// from its positions and uvs; around a vertex, triangles connected through shared edges whose
// uv orientation (handedness) agrees form a group, and the group's tangent is the mean of its
// triangles' tangents projected onto the vertex normal, weighted by the corner angles.
//
// A vertex index whose corners fall in different groups (a mirrored-uv seam, fans that touch at
// one vertex only) is split: copies are appended to `vertices` and `indices` point at them. The
// returned list names, for each vertex appended (in order), the vertex it copies, so per-vertex
// data kept elsewhere (skin weights, morph targets) can follow.
//
// `uvTransform`: the linear part of the transform the normal map is sampled through
// (KHR_texture_transform's rotation and scale; its offset changes no tangent). The tangents are
// MikkTSpace's for the uvs so transformed, so the frame turns with the texture as the material
// places it; with the identity they are the reference's.
//
// Vertices are used as given (the caller gives finite positions and unit normals); any input,
// including NaN, zero-area triangles and indices out of range, terminates in O(n log n) time and
// leaves every tangent either valid as above or all zero (w = 0: "none"). A mesh where no triangle
// has a usable uv mapping (no uvs, all equal) is left untouched, all w = 0.
std::vector<uint32_t> generateTangents(std::vector<Vertex>& vertices,
                                       std::vector<uint32_t>& indices,
                                       const glm::mat2& uvTransform = glm::mat2(1.0f));

}  // namespace myriad::scene
