// Procedural meshes, all with outward normals, counter-clockwise front faces and uvs.
#pragma once

#include <cstdint>

#include "scene/scene.h"

namespace myriad::scene {

// Unit-radius UV sphere centred at the origin.
Mesh makeSphere(uint32_t segments = 48, uint32_t rings = 24);

// Unit icosphere subdivided `subdivisions` times (0 = icosahedron), vertices on the unit sphere.
Mesh makeIcosphere(uint32_t subdivisions);

// Square in the XZ plane, side 1, centred at the origin, normal +Y, uv 0..tiles.
Mesh makePlane(float tiles = 1.0f);

// Axis-aligned cube of side 1 centred at the origin, flat normals per face.
Mesh makeCube();

}  // namespace myriad::scene
