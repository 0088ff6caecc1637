#include "render/bvh.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"

namespace myriad::render {

namespace shading_twin {
using namespace glm;
#include "ray_triangle.glsl"
}  // namespace shading_twin

bool rayHitsTriangle(glm::vec3 origin, glm::vec3 dir, glm::vec3 a, glm::vec3 b, glm::vec3 c,
                     float tMin, float tMax) {
  return shading_twin::rayHitsTriangle(origin, dir, a, b, c, tMin, tMax);
}

namespace {

using gpu_types::BvhHeader;
using gpu_types::BvhNode;
using gpu_types::BvhPush;
using gpu_types::BvhRay;
using gpu_types::BvhTriangle;

static_assert(sizeof(BvhPush) == 48);
static_assert(sizeof(BvhTriangle) == 48);
static_assert(sizeof(BvhNode) == 32);
static_assert(sizeof(BvhHeader) == 16);
static_assert(sizeof(BvhRay) == 32);
static_assert(MYRIAD_BVH_SORT_BINS == 1 << MYRIAD_BVH_SORT_BITS);
static_assert(32 % MYRIAD_BVH_SORT_BITS == 0 && (32 / MYRIAD_BVH_SORT_BITS) % 2 == 0,
              "an even number of sort passes leaves the keys in the first half");

constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkPipelineStageFlags2 kTransfer = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
constexpr VkAccessFlags2 kReadWrite =
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;

// Every buffer starts with room for this many triangles and draws, so a small scene's edits
// reuse them.
constexpr uint32_t kMinimumTriangles = 1024;
constexpr uint32_t kMinimumDraws = 64;
// vkCmdUpdateBuffer's most bytes a call: the draw table is recorded into the command buffer in
// pieces of this, so a frame in flight never sees the next frame's table.
constexpr VkDeviceSize kUpdateChunk = 65536;

uint32_t sortGroups(uint32_t n) {
  return gpu::groupCount(std::max(n, 1u), MYRIAD_BVH_GROUP * MYRIAD_BVH_SORT_ROUNDS);
}

// The scan's chunks of digit counts (bvh_sort_scan.comp): a workgroup each.
uint32_t scanChunks(uint32_t n) {
  return gpu::groupCount(MYRIAD_BVH_SORT_BINS * sortGroups(n), 4 * MYRIAD_BVH_SCAN_GROUP);
}

void computeBarrier(VkCommandBuffer cmd) {
  gpu::memoryBarrier(cmd, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute, kReadWrite);
}

// The draws the G-buffer draws (opaque and alpha-tested, not blended) with their first triangle:
// visibility.cpp's table, which bvh_triangles.comp searches the same way.
std::vector<glm::uvec4> drawTable(const SceneBuffers& scene) {
  std::vector<glm::uvec4> rows(1);
  uint32_t triangles = 0;
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material] || draw.mesh.indexCount < 3) continue;
    rows.emplace_back(triangles, draw.mesh.firstIndex, static_cast<uint32_t>(draw.mesh.vertexOffset),
                      draw.instance);
    triangles += draw.mesh.indexCount / 3;
  }
  rows[0] = glm::uvec4(static_cast<uint32_t>(rows.size() - 1), triangles, 0, 0);
  return rows;
}

}  // namespace

Bvh::Bvh(gpu::Context& context) : context_(context) {
  VkDevice device = context.device;
  std::array<VkDescriptorSetLayoutBinding, MYRIAD_BVH_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  buildLayout_ = gpu::createDescriptorSetLayout(device, bindings);
  traceLayout_ = gpu::createDescriptorSetLayout(
      device, std::span(bindings.data(), MYRIAD_BVH_TRACE_BINDINGS));
  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(BvhPush)};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &buildLayout_;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &pipelineLayout_));
  gather_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_triangles_comp);
  morton_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_morton_comp);
  sortCount_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_sort_count_comp);
  for (uint32_t phase = 0; phase < sortScan_.size(); ++phase) {
    // bvh_sort_scan.comp's kPhase (constant 0): chunks, their totals, the offsets added.
    const VkSpecializationMapEntry entry{0, 0, sizeof(uint32_t)};
    const VkSpecializationInfo spec{1, &entry, sizeof(phase), &phase};
    sortScan_[phase] = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_sort_scan_comp, &spec);
  }
  sortScatter_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_sort_scatter_comp);
  hierarchy_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_hierarchy_comp);
  {
    // bvh_bounds.comp's kFence (constant 0): on GPUs; CPU devices order their atomics anyway.
    const VkBool32 fence = context.info.isCpu ? VK_FALSE : VK_TRUE;
    const VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
    const VkSpecializationInfo spec{1, &entry, sizeof(fence), &fence};
    bounds_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_bounds_comp, &spec);
  }
  query_ = gpu::createComputePipeline(device, pipelineLayout_, spirv::bvh_query_comp);

  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                  MYRIAD_BVH_BINDINGS + MYRIAD_BVH_TRACE_BINDINGS};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(device, &poolInfo, nullptr, &pool_));
  const VkDescriptorSetLayout layouts[] = {buildLayout_, traceLayout_};
  VkDescriptorSet sets[2];
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = pool_;
  alloc.descriptorSetCount = 2;
  alloc.pSetLayouts = layouts;
  VK_CHECK(vkAllocateDescriptorSets(device, &alloc, sets));
  buildSet_ = sets[0];
  traceSet_ = sets[1];
  recorder_ = gpu::createCommandRecorder(context);
}

Bvh::~Bvh() {
  VkDevice device = context_.device;
  vkDeviceWaitIdle(device);
  gpu::destroyCommandRecorder(context_, recorder_);
  for (VkPipeline p : {gather_, morton_, sortCount_, sortScan_[0], sortScan_[1], sortScan_[2],
                       sortScatter_, hierarchy_, bounds_, query_}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  queryArena_.reset();
  arena_.reset();
  if (pool_) vkDestroyDescriptorPool(device, pool_, nullptr);
  if (pipelineLayout_) vkDestroyPipelineLayout(device, pipelineLayout_, nullptr);
  if (buildLayout_) vkDestroyDescriptorSetLayout(device, buildLayout_, nullptr);
  if (traceLayout_) vkDestroyDescriptorSetLayout(device, traceLayout_, nullptr);
}

void Bvh::ensure(uint32_t triangles, uint32_t draws) {
  if (arena_ && triangles <= triangleCapacity_ && draws <= drawCapacity_) return;
  const uint64_t n = std::max<uint64_t>({triangles, kMinimumTriangles, uint64_t(triangleCapacity_)});
  const uint64_t d = std::max<uint64_t>({draws, kMinimumDraws, uint64_t(drawCapacity_)});
  // The largest buffers must fit one storage-buffer range (lavapipe: 128 MiB, 2M triangles' nodes).
  const uint64_t nodeBytes = (2 * n - 1) * sizeof(BvhNode);
  if (nodeBytes > context_.info.maxStorageBufferRange ||
      n * sizeof(BvhTriangle) > context_.info.maxStorageBufferRange ||
      gpu::groupCount(uint32_t(n), MYRIAD_BVH_GROUP) > 65535) {
    throw std::runtime_error("stochastic shadows: " + std::to_string(triangles) +
                             " triangles do not fit one storage buffer's range on this device");
  }
  // Frames in flight read the old buffers through the trace set: done before they go.
  if (arena_) VK_CHECK(vkQueueWaitIdle(context_.queue));
  arena_.reset();
  arena_ = std::make_unique<gpu::Arena>(context_, 4ull << 20);
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  const VkBufferUsageFlags transfer = VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  triangleBuffer_ = arena_->createBuffer(n * sizeof(BvhTriangle), storage | transfer, gpu::MemoryUse::DeviceLocal);
  nodes_ = arena_->createBuffer(nodeBytes, storage | transfer, gpu::MemoryUse::DeviceLocal);
  header_ = arena_->createBuffer(sizeof(BvhHeader), storage | transfer, gpu::MemoryUse::DeviceLocal);
  keys_ = arena_->createBuffer(2 * n * 4, storage | transfer, gpu::MemoryUse::DeviceLocal);
  values_ = arena_->createBuffer(2 * n * 4, storage, gpu::MemoryUse::DeviceLocal);
  // The digit counts, then a word per scan chunk (its total).
  histogram_ = arena_->createBuffer(
      (uint64_t(MYRIAD_BVH_SORT_BINS) * sortGroups(uint32_t(n)) + scanChunks(uint32_t(n))) * 4,
      storage, gpu::MemoryUse::DeviceLocal);
  parents_ = arena_->createBuffer((3 * n) * 4, storage | transfer, gpu::MemoryUse::DeviceLocal);
  boxes_ = arena_->createBuffer(8 * n * 4, storage | transfer, gpu::MemoryUse::DeviceLocal);
  draws_ = arena_->createBuffer((d + 1) * sizeof(glm::uvec4), storage | transfer,
                                gpu::MemoryUse::DeviceLocal);
  triangleCapacity_ = uint32_t(n);
  drawCapacity_ = uint32_t(d);
  triangles_ = 0;
  scene_ = nullptr;
  // The geometry bound last may be gone (a replaced scene frees its buffers before the next frame
  // grows these): the sets are written without it, and record() binds the scene's own again.
  boundVertices_ = boundIndices_ = boundInstances_ = boundMaterials_ = VK_NULL_HANDLE;
  writeSets();
}

void Bvh::writeSets() {
  auto info = [](const gpu::Buffer& b) { return VkDescriptorBufferInfo{b.buffer, 0, VK_WHOLE_SIZE}; };
  auto whole = [](VkBuffer b) { return VkDescriptorBufferInfo{b, 0, VK_WHOLE_SIZE}; };
  // Unbound geometry and rays (no scene or query yet): the draw table stands in, never read.
  auto orDraws = [&](VkBuffer b) { return whole(b ? b : draws_.buffer); };
  const std::array<VkDescriptorBufferInfo, MYRIAD_BVH_BINDINGS> buffers = {
      info(triangleBuffer_), info(nodes_),  info(header_), info(keys_), info(values_),
      info(histogram_), info(parents_), orDraws(boundVertices_), orDraws(boundIndices_),
      info(draws_), orDraws(boundInstances_), orDraws(boundMaterials_), orDraws(rays_.buffer),
      orDraws(hits_.buffer), info(boxes_)};
  std::array<VkWriteDescriptorSet, MYRIAD_BVH_BINDINGS + MYRIAD_BVH_TRACE_BINDINGS> writes{};
  for (uint32_t i = 0; i < writes.size(); ++i) {
    const bool trace = i >= MYRIAD_BVH_BINDINGS;
    const uint32_t binding = trace ? i - MYRIAD_BVH_BINDINGS : i;
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = trace ? traceSet_ : buildSet_;
    writes[i].dstBinding = binding;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[binding];
  }
  vkUpdateDescriptorSets(context_.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

void Bvh::push(VkCommandBuffer cmd, const BvhPush& p) const {
  vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
}

Bvh::Update Bvh::record(VkCommandBuffer cmd, const SceneBuffers& scene, BvhUpdate mode,
                        gpu::PassTimer& timer) {
  const std::vector<glm::uvec4> table = drawTable(scene);
  const uint32_t n = table[0].y;
  // The scene the BVH holds, at its generation or moved since (its move history reaches back to
  // it): the same triangles, maybe elsewhere. A new scene has a new generation and no such
  // history, even where it took the old one's memory.
  const bool sameScene =
      scene_ == &scene && triangles_ == n && boundVertices_ == scene.vertices.buffer &&
      boundIndices_ == scene.indices.buffer && boundInstances_ == scene.instances.buffer &&
      boundMaterials_ == scene.materials.buffer &&
      (scene.generation == generation_ ||
       scene.movedSince(generation_, std::numeric_limits<size_t>::max()).has_value());
  Update update = Update::None;
  if (mode == BvhUpdate::Rebuild || !sameScene) {
    update = Update::Rebuild;
  } else if (mode == BvhUpdate::Refit || scene.generation != generation_) {
    update = Update::Refit;
  }
  if (update == Update::None) return update;

  ensure(n, uint32_t(table.size()));
  // Another scene (even one whose buffers took a freed one's handles), or new geometry buffers:
  // the build set is rewritten, after the frames in flight that built with it finished.
  if (!sameScene || boundVertices_ != scene.vertices.buffer || boundIndices_ != scene.indices.buffer ||
      boundInstances_ != scene.instances.buffer || boundMaterials_ != scene.materials.buffer) {
    VK_CHECK(vkQueueWaitIdle(context_.queue));
    boundVertices_ = scene.vertices.buffer;
    boundIndices_ = scene.indices.buffer;
    boundInstances_ = scene.instances.buffer;
    boundMaterials_ = scene.materials.buffer;
    writeSets();
  }
  timer.beginPass(cmd, update == Update::Rebuild ? "bvh-build" : "bvh-refit");
  // Earlier readers (the last frames' shadow rays) and writers (skinning, this scene's uploads)
  // are done before the tables and boxes are written again.
  gpu::memoryBarrier(cmd, kCompute | kTransfer,
                     kReadWrite | VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute | kTransfer,
                     kReadWrite | VK_ACCESS_2_TRANSFER_WRITE_BIT);
  const VkDeviceSize tableBytes = table.size() * sizeof(glm::uvec4);
  for (VkDeviceSize at = 0; at < tableBytes; at += kUpdateChunk) {
    vkCmdUpdateBuffer(cmd, draws_.buffer, at, std::min(kUpdateChunk, tableBytes - at),
                      reinterpret_cast<const uint8_t*>(table.data()) + at);
  }
  if (n == 0) vkCmdFillBuffer(cmd, header_.buffer, 0, VK_WHOLE_SIZE, 0u);
  gpu::memoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite);
  if (n > 0) {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 1, &buildSet_,
                            0, nullptr);
    BvhPush p{};
    p.params = glm::uvec4(n, 0, 0, 0);
    push(cmd, p);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, gather_);
    vkCmdDispatch(cmd, gpu::groupCount(n, MYRIAD_BVH_GROUP), 1, 1);
    computeBarrier(cmd);
    // The Morton box: the scene's bounds (posed instances grow them), a little larger.
    const glm::vec3 pad = 1e-3f * (scene.bounds.max - scene.bounds.min) + 1e-6f;
    triangles_ = n;
    recordHierarchy(cmd, update == Update::Rebuild, scene.bounds.min - pad, scene.bounds.max + pad);
  }
  triangles_ = n;
  scene_ = &scene;
  generation_ = scene.generation;
  return update;
}

void Bvh::recordHierarchy(VkCommandBuffer cmd, bool rebuild, glm::vec3 lo, glm::vec3 hi) {
  const uint32_t n = triangles_;
  const uint32_t groups = gpu::groupCount(n, MYRIAD_BVH_GROUP);
  const uint32_t sorts = sortGroups(n);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 1, &buildSet_, 0,
                          nullptr);
  BvhPush p{};
  p.boundsMin = glm::vec4(lo, 0.0f);
  p.boundsMax = glm::vec4(hi, 0.0f);
  p.params = glm::uvec4(n, 0, 0, sorts);
  if (rebuild) {
    push(cmd, p);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, morton_);
    vkCmdDispatch(cmd, groups, 1, 1);
    computeBarrier(cmd);
    for (uint32_t pass = 0; pass < 32 / MYRIAD_BVH_SORT_BITS; ++pass) {
      p.params.y = pass * MYRIAD_BVH_SORT_BITS;
      p.params.z = pass % 2;  // the half it reads
      push(cmd, p);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sortCount_);
      vkCmdDispatch(cmd, sorts, 1, 1);
      computeBarrier(cmd);
      const uint32_t chunks = scanChunks(n);
      for (uint32_t phase = 0; phase < sortScan_.size(); ++phase) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sortScan_[phase]);
        vkCmdDispatch(cmd, phase == 1 ? 1 : chunks, 1, 1);
        computeBarrier(cmd);
      }
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sortScatter_);
      vkCmdDispatch(cmd, sorts, 1, 1);
      computeBarrier(cmd);
    }
    p.params.y = p.params.z = 0;
    push(cmd, p);
    if (n > 1) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, hierarchy_);
      vkCmdDispatch(cmd, gpu::groupCount(n - 1, MYRIAD_BVH_GROUP), 1, 1);
    }
  }
  // The bounds pass's arrival counters (after the parents, 2n - 1 words in) start at 0, its
  // merged boxes empty: minima at the largest bits, maxima at the smallest.
  if (n > 1) {
    gpu::memoryBarrier(cmd, kCompute, kReadWrite, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const VkDeviceSize internal = VkDeviceSize(n - 1) * 4;
    vkCmdFillBuffer(cmd, parents_.buffer, VkDeviceSize(2 * n - 1) * 4, internal, 0u);
    vkCmdFillBuffer(cmd, boxes_.buffer, 0, 4 * internal, 0xFFFFFFFFu);
    vkCmdFillBuffer(cmd, boxes_.buffer, 4 * internal, 4 * internal, 0u);
    gpu::memoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite);
  }
  computeBarrier(cmd);
  push(cmd, p);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, bounds_);
  vkCmdDispatch(cmd, groups, 1, 1);
  // The shadow rays read triangles, nodes and header next.
  gpu::memoryBarrier(cmd, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute | kTransfer,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
}

void Bvh::build(std::span<const BvhTriangle> triangles) {
  const uint32_t n = static_cast<uint32_t>(triangles.size());
  ensure(n, kMinimumDraws);
  scene_ = nullptr;  // a scene's next frame rebuilds
  gpu::Arena staging(context_, 1ull << 20);
  const VkDeviceSize bytes = std::max<VkDeviceSize>(triangles.size_bytes(), 16);
  gpu::Buffer upload = staging.createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, gpu::MemoryUse::Upload);
  if (n > 0) std::memcpy(upload.mapped, triangles.data(), triangles.size_bytes());
  scene::Bounds box;
  for (const BvhTriangle& t : triangles) {
    box.extend(glm::vec3(t.v0));
    box.extend(glm::vec3(t.v1));
    box.extend(glm::vec3(t.v2));
  }
  VkCommandBuffer cmd = gpu::beginCommands(context_, recorder_);
  if (n > 0) {
    const VkBufferCopy region{0, 0, triangles.size_bytes()};
    vkCmdCopyBuffer(cmd, upload.buffer, triangleBuffer_.buffer, 1, &region);
  } else {
    vkCmdFillBuffer(cmd, header_.buffer, 0, VK_WHOLE_SIZE, 0u);
  }
  gpu::memoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite);
  triangles_ = n;
  if (n > 0) {
    const glm::vec3 pad = 1e-3f * (box.max - box.min) + 1e-6f;
    recordHierarchy(cmd, true, box.min - pad, box.max + pad);
  }
  gpu::submitAndWait(context_, recorder_);
}

std::vector<uint32_t> Bvh::occluded(std::span<const BvhRay> rays) {
  const uint32_t count = static_cast<uint32_t>(rays.size());
  if (count == 0) return {};
  if (!queryArena_ || rays_.size < rays.size_bytes()) {
    VK_CHECK(vkQueueWaitIdle(context_.queue));
    queryArena_ = std::make_unique<gpu::Arena>(context_, 1ull << 20);
    rays_ = queryArena_->createBuffer(rays.size_bytes(), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                      gpu::MemoryUse::Upload);
    hits_ = queryArena_->createBuffer(VkDeviceSize(count) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                      gpu::MemoryUse::Readback);
    writeSets();
  }
  std::memcpy(rays_.mapped, rays.data(), rays.size_bytes());
  VkCommandBuffer cmd = gpu::beginCommands(context_, recorder_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 1, &buildSet_, 0,
                          nullptr);
  BvhPush p{};
  p.params = glm::uvec4(count, 0, 0, 0);
  push(cmd, p);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, query_);
  vkCmdDispatch(cmd, gpu::groupCount(count, MYRIAD_BVH_GROUP), 1, 1);
  gpu::memoryBarrier(cmd, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  gpu::submitAndWait(context_, recorder_);
  std::vector<uint32_t> out(count);
  std::memcpy(out.data(), hits_.mapped, out.size() * 4);
  return out;
}

std::vector<BvhNode> Bvh::readNodes() {
  const uint32_t n = triangles_;
  if (n == 0) return {};
  const VkDeviceSize bytes = VkDeviceSize(2 * n - 1) * sizeof(BvhNode);
  gpu::Arena staging(context_, 1ull << 20);
  gpu::Buffer copy = staging.createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUse::Readback);
  VkCommandBuffer cmd = gpu::beginCommands(context_, recorder_);
  const VkBufferCopy region{0, 0, bytes};
  vkCmdCopyBuffer(cmd, nodes_.buffer, copy.buffer, 1, &region);
  gpu::memoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  gpu::submitAndWait(context_, recorder_);
  std::vector<BvhNode> nodes(2 * n - 1);
  std::memcpy(nodes.data(), copy.mapped, bytes);
  return nodes;
}

}  // namespace myriad::render
