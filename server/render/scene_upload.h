// What building and editing a SceneBuffers share (scene_buffers.cpp builds it, scene_edits.cpp
// edits it): uploads through a staging buffer, the host-to-GPU conversions of lights and
// materials, and the light buffers' block size. Internal to those files.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/gpu_types.h"
#include "render/light_packing.h"
#include "scene/scene.h"

namespace myriad::render::scene_upload {

constexpr VkDeviceSize kLightBlockSize = 256ull << 10;
// Light buffers start exactly full; the first growth makes room for at least this many.
constexpr uint32_t kFirstGrownLightCapacity = 64;

// Host data copied into a GPU buffer at `offset`.
struct Upload {
  const gpu::Buffer* destination;
  VkDeviceSize offset;
  const void* data;
  VkDeviceSize size;
};

// A GPU-side copy from the start of one buffer to the start of another.
struct DeviceCopy {
  const gpu::Buffer* source;
  const gpu::Buffer* destination;
  VkDeviceSize size;
};

// Runs the device copies, then every upload through one staging buffer, in one submission.
void transfer(gpu::Context& context, gpu::CommandRecorder& recorder,
              const std::vector<DeviceCopy>& copies, const std::vector<Upload>& uploads);

inline GpuPointLight toGpu(const scene::PointLight& l) { return packLight(l); }
GpuMaterial toGpu(const scene::Material& m);

// Whether the material needs the emissive target: emission is factor x strength (x texture),
// zero whenever the factor or the strength is; an unlit material emits its base colour
// (material_core.glsl's withUnlit); and the target's alpha carries a dielectric F0 other than
// glTF's 0.04 (frame.glsl's loadSurfaceWithDepth).
bool emitsLight(const scene::Material& m);
bool hasTexture(const scene::Material& m);

// A new SceneBuffers::generation: distinct across every scene of the process.
uint64_t nextGeneration();

// Element writes in index order, the last write of an index winning, merged into runs of
// consecutive indices: one copy region per run ("generate 100,000 lights" is one region).
template <typename Gpu, typename Write, typename Convert>
std::vector<Upload> elementUploads(const std::vector<Write>& writes, const gpu::Buffer& destination,
                                   std::vector<Gpu>& staged, Convert convert) {
  std::vector<size_t> order(writes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return writes[a].index < writes[b].index; });
  std::vector<uint32_t> indices;
  staged.clear();
  staged.reserve(order.size());
  for (size_t k = 0; k < order.size(); ++k) {
    const Write& w = writes[order[k]];
    if (k + 1 < order.size() && writes[order[k + 1]].index == w.index) continue;  // a later one wins
    indices.push_back(w.index);
    staged.push_back(convert(w));
  }
  std::vector<Upload> uploads;
  for (size_t first = 0; first < indices.size();) {
    size_t end = first + 1;
    while (end < indices.size() && indices[end] == indices[end - 1] + 1) ++end;
    uploads.push_back({&destination, VkDeviceSize(indices[first]) * sizeof(Gpu), &staged[first],
                       VkDeviceSize(end - first) * sizeof(Gpu)});
    first = end;
  }
  return uploads;
}

}  // namespace myriad::render::scene_upload
