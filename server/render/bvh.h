// A bounding volume hierarchy over the scene's triangles, built on the GPU in compute, for the
// shadow rays of stochastic local shadows (render/stochastic_shadows.h). No ray-tracing hardware:
// every pass is a compute shader (shaders/bvh_*.comp), so it runs on lavapipe as on the H200.
//
// A linear BVH (Lauterbach 2009; Karras, HPG 2012):
//   triangles  one invocation per triangle of the G-buffer's draws into world space (posed
//              vertices included: skinned instances draw their own region), in draw-table order
//   morton     a 30-bit Morton code of each centroid in the scene's bounds
//   sort       a stable radix sort of the codes, 8 bits a pass (count, scan in 3, scatter) x 4
//   hierarchy  Karras's internal nodes, one invocation each, independent of each other
//   bounds     boxes bottom-up: each leaf climbs, the second child to arrive at a node makes its box
// A refit (geometry moved, same triangles) runs triangles and bounds only: the hierarchy stays,
// its boxes follow. Traversal (shaders/bvh_trace.glsl): any hit, a stack per invocation.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "bvh_types.h"
#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/scene_buffers.h"
#include "render/tuning.h"

namespace myriad::render {

// The C++ twin of the GPU's triangle test (shaders/ray_triangle.glsl, the same source): the
// tests' brute-force answer.
bool rayHitsTriangle(glm::vec3 origin, glm::vec3 dir, glm::vec3 a, glm::vec3 b, glm::vec3 c,
                     float tMin, float tMax);

class Bvh {
 public:
  explicit Bvh(gpu::Context& context);
  ~Bvh();
  Bvh(const Bvh&) = delete;
  Bvh& operator=(const Bvh&) = delete;

  enum class Update { None, Refit, Rebuild };

  // Records what `scene`'s BVH needs this frame (per `mode`: Auto rebuilds for another scene or
  // triangle count, refits after its instances or poses moved, else nothing; a material's alpha
  // edit shows at the next of those), timed as "bvh-build" or
  // "bvh-refit". Leaves the trace set's buffers ready for compute reads. The caller binds its own
  // compute sets again afterwards. May wait for the queue to go idle (when its buffers grow or
  // the scene's geometry buffers change: a descriptor set in flight is never rewritten).
  // Throws std::runtime_error when the scene's triangles do not fit the device's storage range.
  Update record(VkCommandBuffer cmd, const SceneBuffers& scene, BvhUpdate mode,
                gpu::PassTimer& timer);

  // For tests and measurements, synchronous on the queue: builds over `triangles` (world space),
  // then answers whether each ray is occluded (1) or not (0).
  void build(std::span<const gpu_types::BvhTriangle> triangles);
  std::vector<uint32_t> occluded(std::span<const gpu_types::BvhRay> rays);
  // The nodes as built (2n - 1 after build(); tests check the hierarchy's shape).
  std::vector<gpu_types::BvhNode> readNodes();

  // What the shadow rays bind (shaders/bvh_trace.glsl): triangles, nodes, header.
  VkDescriptorSetLayout traceSetLayout() const { return traceLayout_; }
  VkDescriptorSet traceSet() const { return traceSet_; }
  uint32_t triangleCount() const { return triangles_; }
  uint64_t gpuMemoryBytes() const { return arena_ ? arena_->bytesAllocated() : 0; }

 private:
  // Fits the buffers to `triangles` and `draws` (waits for the queue when they must grow).
  void ensure(uint32_t triangles, uint32_t draws);
  // The passes after the triangles are in place: a rebuild (morton, sort, hierarchy) and the
  // bounds, or the bounds alone.
  void recordHierarchy(VkCommandBuffer cmd, bool rebuild, glm::vec3 lo, glm::vec3 hi);
  void writeSets();
  void push(VkCommandBuffer cmd, const gpu_types::BvhPush& p) const;

  gpu::Context& context_;
  VkDescriptorSetLayout buildLayout_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout traceLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet buildSet_ = VK_NULL_HANDLE;
  VkDescriptorSet traceSet_ = VK_NULL_HANDLE;
  VkPipeline gather_ = VK_NULL_HANDLE;
  VkPipeline morton_ = VK_NULL_HANDLE;
  VkPipeline sortCount_ = VK_NULL_HANDLE;
  std::array<VkPipeline, 3> sortScan_{};  // its three phases (bvh_sort_scan.comp kPhase)
  VkPipeline sortScatter_ = VK_NULL_HANDLE;
  VkPipeline hierarchy_ = VK_NULL_HANDLE;
  VkPipeline bounds_ = VK_NULL_HANDLE;
  VkPipeline query_ = VK_NULL_HANDLE;

  std::unique_ptr<gpu::Arena> arena_;
  uint32_t triangleCapacity_ = 0;
  uint32_t drawCapacity_ = 0;
  gpu::Buffer triangleBuffer_, nodes_, header_, keys_, values_, histogram_, parents_, boxes_, draws_;
  // The geometry the build set reads (the scene's buffers) and the test's rays.
  VkBuffer boundVertices_ = VK_NULL_HANDLE, boundIndices_ = VK_NULL_HANDLE,
           boundInstances_ = VK_NULL_HANDLE, boundMaterials_ = VK_NULL_HANDLE;
  std::unique_ptr<gpu::Arena> queryArena_;
  gpu::Buffer rays_, hits_;
  gpu::CommandRecorder recorder_;  // build() and occluded()

  // What the BVH holds: the triangles of this scene at this generation.
  uint32_t triangles_ = 0;
  const SceneBuffers* scene_ = nullptr;
  uint64_t generation_ = 0;
};

}  // namespace myriad::render
