// The scene on the GPU: one vertex and one index buffer for every mesh (plus the light proxy
// sphere), and storage buffers for instances, materials and lights. Built from a scene::Scene in
// one upload; rebuilt when the scene changes.
#pragma once

#include <cstdint>
#include <vector>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "scene/scene.h"

namespace myriad::render {

struct MeshRange {
  uint32_t firstIndex = 0;
  uint32_t indexCount = 0;
  int32_t vertexOffset = 0;
};

struct DrawItem {
  MeshRange mesh;
  uint32_t instance = 0;  // index into the instance buffer, passed as firstInstance
};

struct SceneBuffers {
  SceneBuffers(gpu::Context& context, gpu::CommandRecorder& recorder, const scene::Scene& scene);

  gpu::Arena arena;
  gpu::Buffer vertices;
  gpu::Buffer indices;
  gpu::Buffer instances;
  gpu::Buffer materials;
  gpu::Buffer lights;        // where the lights are this frame (animation writes here)
  gpu::Buffer lightOrigins;  // where the scene put them
  std::vector<DrawItem> draws;
  MeshRange lightProxy;  // icosphere circumscribing the unit sphere (volumes, markers)
  uint32_t lightCount = 0;
  scene::Bounds bounds;
};

// Scale that makes a mesh with vertices on the unit sphere contain the unit sphere: 1 / the
// smallest distance from the centre to any triangle's plane. A proxy that merely touched the
// sphere at its vertices would cut light off between them.
float circumscribeScale(const scene::Mesh& unitSphereMesh);

}  // namespace myriad::render
