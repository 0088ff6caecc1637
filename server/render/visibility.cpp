#include "render/visibility.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <vector>

#include "embedded_shaders.h"
#include "gpu/pipelines.h"
#include "gpu/vk_check.h"
#include "render/gpu_types.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

static_assert(sizeof(scene::Vertex) == 16 * sizeof(float), "visibility.glsl reads 16 floats a vertex");

using gpu::ImageTransition;

// The formats the resolve pass stores (its GLSL layout qualifiers say the same).
constexpr VkFormat kStorageFormats[] = {kNormalFormat, kBaseColorStorageFormat, kMaterialFormat,
                                        kUvFormat, kEmissiveFormat};

bool deviceSupports(gpu::Context& context) {
  if (!context.int64Atomics) return false;
  // The resolve reduces the clusters' point bounds per subgroup (cluster_bounds.glsl).
  if (!context.info.computeSubgroupShuffle) return false;
  for (VkFormat format : kStorageFormats) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, format, &properties);
    if (!(properties.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT)) return false;
  }
  VkFormatProperties depth;
  vkGetPhysicalDeviceFormatProperties(context.physicalDevice, kDepthFormat, &depth);
  return (depth.optimalTilingFeatures & VK_FORMAT_FEATURE_TRANSFER_DST_BIT) != 0;
}

// The draws the G-buffer pass draws (not the blended ones), in its order, with their first
// triangle ids: the table visibility.glsl's triangleRef searches. Returns the triangle count.
uint32_t writeDrawTable(const SceneBuffers& scene, gpu::Buffer& table) {
  auto* rows = static_cast<glm::uvec4*>(table.mapped);
  uint32_t draws = 0;
  uint32_t triangles = 0;
  for (const DrawItem& draw : scene.draws) {
    if (scene.blend[draw.material] || draw.mesh.indexCount < 3) continue;
    rows[1 + draws++] = glm::uvec4(triangles, draw.mesh.firstIndex,
                                   static_cast<uint32_t>(draw.mesh.vertexOffset), draw.instance);
    triangles += draw.mesh.indexCount / 3;
  }
  rows[0] = glm::uvec4(draws, triangles, 0, 0);
  return triangles;
}

uint32_t drawnCount(const SceneBuffers& scene) {
  return static_cast<uint32_t>(std::count_if(scene.draws.begin(), scene.draws.end(),
                                             [&](const DrawItem& d) { return !scene.blend[d.material]; }));
}

}  // namespace

ComputeGBuffer::ComputeGBuffer(gpu::Context& context, VkDescriptorSetLayout sceneSetLayout,
                               uint32_t slots)
    : context_(context) {
  supported_ = deviceSupports(context);
  if (!supported_) return;
  VkPhysicalDeviceProperties properties;
  vkGetPhysicalDeviceProperties(context.physicalDevice, &properties);
  maxStorageRange_ = properties.limits.maxStorageBufferRange;

  std::array<VkDescriptorSetLayoutBinding, MYRIAD_VISIBILITY_BINDINGS> bindings{};
  for (uint32_t i = 0; i < bindings.size(); ++i) {
    const bool image = i >= MYRIAD_BINDING_VISIBILITY_NORMAL && i <= MYRIAD_BINDING_VISIBILITY_EMISSIVE;
    bindings[i] = {i, image ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                   VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  setLayout_ = gpu::createDescriptorSetLayout(context.device, bindings);
  VkDescriptorSetLayout setLayouts[] = {sceneSetLayout, setLayout_};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 2;
  layoutInfo.pSetLayouts = setLayouts;
  VK_CHECK(vkCreatePipelineLayout(context.device, &layoutInfo, nullptr, &layout_));
  visibility_ = gpu::createComputePipeline(context.device, layout_, spirv::visibility_comp);
  tiles_ = gpu::createComputePipeline(context.device, layout_, spirv::visibility_tiles_comp);
  resolve_ = gpu::createComputePipeline(context.device, layout_, spirv::visibility_resolve_comp);

  const VkDescriptorPoolSize sizes[] = {
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, slots * (MYRIAD_BINDING_VISIBILITY_NORMAL + 1)},
      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
       slots * (MYRIAD_BINDING_VISIBILITY_EMISSIVE + 1 - MYRIAD_BINDING_VISIBILITY_NORMAL)}};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = slots;
  poolInfo.poolSizeCount = 2;
  poolInfo.pPoolSizes = sizes;
  VK_CHECK(vkCreateDescriptorPool(context.device, &poolInfo, nullptr, &pool_));
}

ComputeGBuffer::~ComputeGBuffer() {
  VkDevice device = context_.device;
  for (VkPipeline p : {visibility_, tiles_, resolve_}) {
    if (p) vkDestroyPipeline(device, p, nullptr);
  }
  if (layout_) vkDestroyPipelineLayout(device, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device, setLayout_, nullptr);
  if (pool_) vkDestroyDescriptorPool(device, pool_, nullptr);
}

bool ComputeGBuffer::qualifies(const SceneBuffers& scene, VkExtent2D extent) const {
  if (!supported_) return false;
  for (const DrawItem& draw : scene.draws) {
    const uint32_t m = draw.material;
    if (scene.blend[m]) continue;  // the forward pass draws it, whichever path made the G-buffer
    // A clear coat or sheen needs the layers target, which only the raster path writes.
    if (scene.alphaTest[m] || scene.textured[m] || scene.layered[m]) return false;
  }
  const VkDeviceSize keys = VkDeviceSize(extent.width) * extent.height * sizeof(uint64_t);
  return keys <= maxStorageRange_ && scene.vertices.size <= maxStorageRange_ &&
         scene.indices.size <= maxStorageRange_;
}

void ComputeGBuffer::record(VkCommandBuffer cmd, std::unique_ptr<Slot>& slot,
                            const FrameTargets& t, const SceneBuffers& scene,
                            VkDescriptorSet sceneSet, gpu::PassTimer& timer) {
  // Fit the slot to the frame (its last frame has finished: the renderer waited for it).
  const uint32_t draws = drawnCount(scene);
  const VkExtent2D extent = t.extent;
  if (!slot || slot->extent.width != extent.width || slot->extent.height != extent.height ||
      slot->drawCapacity < draws) {
    VkDescriptorSet set = slot ? slot->set : VK_NULL_HANDLE;
    slot.reset();
    slot = std::make_unique<Slot>(context_);
    if (!set) {
      VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
      alloc.descriptorPool = pool_;
      alloc.descriptorSetCount = 1;
      alloc.pSetLayouts = &setLayout_;
      VK_CHECK(vkAllocateDescriptorSets(context_.device, &alloc, &set));
    }
    slot->set = set;
    slot->extent = extent;
    slot->drawCapacity = std::max(draws, 64u);
    const VkDeviceSize pixels = VkDeviceSize(extent.width) * extent.height;
    const VkBufferUsageFlags transfer =
        VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    slot->keys = slot->arena.createBuffer(pixels * sizeof(uint64_t),
                                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | transfer,
                                          gpu::MemoryUse::DeviceLocal);
    slot->depth = slot->arena.createBuffer(pixels * sizeof(float),
                                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | transfer,
                                           gpu::MemoryUse::DeviceLocal);
    slot->large = slot->arena.createBuffer(
        sizeof(gpu_types::VisibilityLargeHeader) +
            VkDeviceSize(MYRIAD_VISIBILITY_LARGE_CAPACITY) * sizeof(gpu_types::VisibilityTriangle),
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | transfer,
        gpu::MemoryUse::DeviceLocal);
    slot->draws = slot->arena.createBuffer((slot->drawCapacity + 1) * sizeof(glm::uvec4),
                                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, gpu::MemoryUse::Upload);
  }
  const uint32_t triangles = writeDrawTable(scene, slot->draws);

  // The set: this frame's scene geometry, the slot's buffers, the frame's targets.
  const VkDescriptorBufferInfo buffers[] = {
      {scene.vertices.buffer, 0, VK_WHOLE_SIZE}, {scene.indices.buffer, 0, VK_WHOLE_SIZE},
      {slot->draws.buffer, 0, VK_WHOLE_SIZE},    {slot->keys.buffer, 0, VK_WHOLE_SIZE},
      {slot->depth.buffer, 0, VK_WHOLE_SIZE},    {slot->large.buffer, 0, VK_WHOLE_SIZE}};
  const VkDescriptorBufferInfo marks{t.clusterMarks.buffer, 0, VK_WHOLE_SIZE};
  const VkImageView views[] = {t.normal.view, t.baseColorStorage, t.material.view, t.uv.view,
                               t.emissive.view};
  VkDescriptorImageInfo images[std::size(views)];
  std::array<VkWriteDescriptorSet, MYRIAD_VISIBILITY_BINDINGS> writes{};
  for (uint32_t i = 0; i < writes.size(); ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = slot->set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    if (i == MYRIAD_BINDING_VISIBILITY_CLUSTER_MARKS) {
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &marks;
    } else if (i < MYRIAD_BINDING_VISIBILITY_NORMAL) {
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &buffers[i];
    } else {
      const uint32_t k = i - MYRIAD_BINDING_VISIBILITY_NORMAL;
      images[k] = {VK_NULL_HANDLE, views[k], VK_IMAGE_LAYOUT_GENERAL};
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
      writes[i].pImageInfo = &images[k];
    }
  }
  vkUpdateDescriptorSets(context_.device, static_cast<uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);

  constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  constexpr VkPipelineStageFlags2 kTransfer = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  constexpr VkAccessFlags2 kReadWrite =
      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  timer.beginPass(cmd, "visibility");
  // Keys start at "nothing drawn" (all ones: above every depth's bits), the queue empty. Their
  // previous readers (the slot's last frame: resolve, the tile pass and its indirect read) are
  // done before these writes.
  gpu::bufferBarrier(cmd, slot->keys, kCompute, VK_ACCESS_2_NONE, kTransfer,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT);
  gpu::bufferBarrier(cmd, slot->large, kCompute | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_NONE, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  vkCmdFillBuffer(cmd, slot->keys.buffer, 0, VK_WHOLE_SIZE, 0xFFFFFFFFu);
  const gpu_types::VisibilityLargeHeader header{
      {gpu::groupCount(extent.width, MYRIAD_VISIBILITY_TILE),
       gpu::groupCount(extent.height, MYRIAD_VISIBILITY_TILE), 0, MYRIAD_VISIBILITY_LARGE_CAPACITY}};
  vkCmdUpdateBuffer(cmd, slot->large.buffer, 0, sizeof(header), &header);
  gpu::bufferBarrier(cmd, slot->keys, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite);
  gpu::bufferBarrier(cmd, slot->large, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute, kReadWrite);

  // Both sets: this layout has no push constants, so it is not compatible with the frame's.
  const VkDescriptorSet sets[] = {sceneSet, slot->set};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 2, sets, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, visibility_);
  if (triangles > 0) vkCmdDispatch(cmd, gpu::groupCount(triangles, MYRIAD_VISIBILITY_GROUP), 1, 1);
  // The queue (and its count, the tile pass's group count) and the keys so far.
  gpu::bufferBarrier(cmd, slot->large, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     kCompute | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  gpu::bufferBarrier(cmd, slot->keys, kCompute, kReadWrite, kCompute, kReadWrite);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, tiles_);
  vkCmdDispatchIndirect(cmd, slot->large.buffer, 0);

  timer.beginPass(cmd, "resolve");
  gpu::bufferBarrier(cmd, slot->keys, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCompute,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  // Depth's last reader was the slot's previous copy into the depth target.
  gpu::bufferBarrier(cmd, slot->depth, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE, kCompute,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  // Last frame's readers of the targets: raster lighting (fragment) and compute lighting, views.
  const VkPipelineStageFlags2 reader = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCompute;
  auto toStorage = [&](const gpu::Image& image) {
    return ImageTransition{&image, reader, VK_ACCESS_2_NONE, kCompute,
                           VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                           VK_IMAGE_LAYOUT_GENERAL};
  };
  const ImageTransition before[] = {toStorage(t.normal), toStorage(t.baseColor),
                                    toStorage(t.material), toStorage(t.uv), toStorage(t.emissive)};
  gpu::barrier(cmd, before);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve_);
  vkCmdDispatch(cmd, gpu::groupCount(extent.width, MYRIAD_PIXEL_GROUP),
                gpu::groupCount(extent.height, MYRIAD_PIXEL_GROUP), 1);
  // The cluster marks (FrameUniforms.written.w), for the lighting's compute passes.
  gpu::bufferBarrier(cmd, t.clusterMarks, kCompute, kReadWrite, kCompute,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT);

  // Depth: the resolved values into the depth target, as the raster path's depth test left it.
  gpu::bufferBarrier(cmd, slot->depth, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  const ImageTransition depthToCopy[] = {
      {&t.depth, reader | VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                     VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL}};
  gpu::barrier(cmd, depthToCopy);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
  region.imageExtent = {extent.width, extent.height, 1};
  vkCmdCopyBufferToImage(cmd, slot->depth.buffer, t.depth.image,
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);

  auto toSampled = [&](const gpu::Image& image) {
    return ImageTransition{&image, kCompute, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, reader,
                           VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                           VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
  };
  const ImageTransition after[] = {
      toSampled(t.normal), toSampled(t.baseColor), toSampled(t.material), toSampled(t.uv),
      toSampled(t.emissive),
      // Not written here (no draw has layers: qualifies), but read-only like the rest for the
      // lighting's descriptor set.
      {&t.layers, reader, VK_ACCESS_2_NONE, reader, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL},
      {&t.depth, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
       reader | VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
           VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}};
  gpu::barrier(cmd, after);
}

}  // namespace myriad::render
