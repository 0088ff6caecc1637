#include "gpu/resources.h"

#include <algorithm>
#include <string>
#include <utility>

#include "gpu/vk_check.h"

namespace myriad::gpu {

namespace {

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

}  // namespace

uint32_t findMemoryType(const VkPhysicalDeviceMemoryProperties& props, uint32_t typeBits,
                        VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) {
  for (VkMemoryPropertyFlags want : {required | preferred, required}) {
    for (uint32_t i = 0; i < props.memoryTypeCount; ++i) {
      if ((typeBits & (1u << i)) && (props.memoryTypes[i].propertyFlags & want) == want) return i;
    }
  }
  throw std::runtime_error("no Vulkan memory type has the required properties");
}

namespace {

// The memory type place() picks for `use` among `typeBits`.
uint32_t memoryTypeFor(const VkPhysicalDeviceMemoryProperties& props, uint32_t typeBits,
                       MemoryUse use) {
  VkMemoryPropertyFlags required = 0;
  VkMemoryPropertyFlags preferred = 0;
  switch (use) {
    case MemoryUse::DeviceLocal: required = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT; break;
    case MemoryUse::Upload:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      break;
    case MemoryUse::Readback:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
      break;
  }
  return findMemoryType(props, typeBits, required, preferred);
}

}  // namespace

std::string describeMemoryUse(Context& context, MemoryUse use) {
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = 1 << 16;
  info.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer probe = VK_NULL_HANDLE;
  VK_CHECK(vkCreateBuffer(context.device, &info, nullptr, &probe));
  VkMemoryRequirements requirements;
  vkGetBufferMemoryRequirements(context.device, probe, &requirements);
  vkDestroyBuffer(context.device, probe, nullptr);
  const VkPhysicalDeviceMemoryProperties& props = context.memoryProperties;
  const uint32_t type = memoryTypeFor(props, requirements.memoryTypeBits, use);
  const VkMemoryPropertyFlags flags = props.memoryTypes[type].propertyFlags;
  std::string text = "type " + std::to_string(type) + ":";
  const std::pair<VkMemoryPropertyFlags, const char*> names[] = {
      {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "device-local"},
      {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, "host-visible"},
      {VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, "host-coherent"},
      {VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "host-cached"}};
  const char* separator = " ";
  for (const auto& [bit, name] : names) {
    if (flags & bit) {
      text += separator;
      text += name;
      separator = ", ";
    }
  }
  if (!(flags & VK_MEMORY_PROPERTY_HOST_CACHED_BIT)) text += " (not host-cached)";
  const uint32_t heap = props.memoryTypes[type].heapIndex;
  text += " (heap " + std::to_string(heap) + ", " +
          std::to_string(props.memoryHeaps[heap].size >> 20) + " MiB)";
  return text;
}

Arena::Placement Arena::place(const VkMemoryRequirements& requirements, MemoryUse use) {
  uint32_t type = memoryTypeFor(context_->memoryProperties, requirements.memoryTypeBits, use);
  bool mapped = use != MemoryUse::DeviceLocal;
  // bufferImageGranularity keeps linear and optimal resources from sharing a page; aligning every
  // placement to it is simpler than tracking neighbours and costs little at these sizes.
  VkDeviceSize granularity = 1;
  {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(context_->physicalDevice, &p);
    granularity = p.limits.bufferImageGranularity;
  }
  VkDeviceSize alignment = std::max(requirements.alignment, granularity);

  for (Block& block : blocks_) {
    if (block.memoryType != type || (block.mapped != nullptr) != mapped) continue;
    VkDeviceSize offset = alignUp(block.used, alignment);
    if (offset + requirements.size <= block.size) {
      block.used = offset + requirements.size;
      return {block.memory, offset,
              block.mapped ? static_cast<char*>(block.mapped) + offset : nullptr};
    }
  }
  Block block;
  block.memoryType = type;
  block.size = std::max(minBlockSize_, alignUp(requirements.size, alignment));
  VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  info.allocationSize = block.size;
  info.memoryTypeIndex = type;
  VK_CHECK(vkAllocateMemory(context_->device, &info, nullptr, &block.memory));
  if (mapped) {
    VkResult result = vkMapMemory(context_->device, block.memory, 0, VK_WHOLE_SIZE, 0, &block.mapped);
    if (result != VK_SUCCESS) {
      vkFreeMemory(context_->device, block.memory, nullptr);
      VK_CHECK(result);
    }
  }
  block.used = requirements.size;
  blocks_.push_back(block);
  return {block.memory, 0, block.mapped};
}

Buffer Arena::createBuffer(VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use) {
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = std::max<VkDeviceSize>(size, 16);  // zero-sized buffers are invalid; keep it bindable
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  Buffer buffer;
  buffer.size = info.size;
  VK_CHECK(vkCreateBuffer(context_->device, &info, nullptr, &buffer.buffer));
  buffers_.push_back(buffer.buffer);
  VkMemoryRequirements requirements;
  vkGetBufferMemoryRequirements(context_->device, buffer.buffer, &requirements);
  Placement placement = place(requirements, use);
  VK_CHECK(vkBindBufferMemory(context_->device, buffer.buffer, placement.memory, placement.offset));
  buffer.mapped = placement.mapped;
  return buffer;
}

Image Arena::createImage2D(VkExtent2D extent, VkFormat format, VkImageUsageFlags usage,
                           uint32_t mipLevels, VkImageCreateFlags flags) {
  bool depth = format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM ||
               format == VK_FORMAT_D24_UNORM_S8_UINT || format == VK_FORMAT_D32_SFLOAT_S8_UINT;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {extent.width, extent.height, 1};
  info.flags = flags;
  info.mipLevels = mipLevels;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  Image image;
  image.format = format;
  image.extent = extent;
  image.aspect = depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
  image.mipLevels = mipLevels;
  VK_CHECK(vkCreateImage(context_->device, &info, nullptr, &image.image));
  images_.push_back(image.image);
  VkMemoryRequirements requirements;
  vkGetImageMemoryRequirements(context_->device, image.image, &requirements);
  Placement placement = place(requirements, MemoryUse::DeviceLocal);
  VK_CHECK(vkBindImageMemory(context_->device, image.image, placement.memory, placement.offset));

  VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = image.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = format;
  view.subresourceRange = {image.aspect, 0, mipLevels, 0, 1};
  // An image with extended usage may carry a usage its own format lacks (another view's, e.g.
  // storage through a UNORM view of an sRGB image): its own view leaves storage out.
  VkImageViewUsageCreateInfo viewUsage{VK_STRUCTURE_TYPE_IMAGE_VIEW_USAGE_CREATE_INFO};
  viewUsage.usage = usage & ~VK_IMAGE_USAGE_STORAGE_BIT;
  if (flags & VK_IMAGE_CREATE_EXTENDED_USAGE_BIT) view.pNext = &viewUsage;
  VK_CHECK(vkCreateImageView(context_->device, &view, nullptr, &image.view));
  views_.push_back(image.view);
  return image;
}

VkImageView Arena::createView(const Image& image, VkFormat format, VkImageUsageFlags usage) {
  VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  VkImageViewUsageCreateInfo viewUsage{VK_STRUCTURE_TYPE_IMAGE_VIEW_USAGE_CREATE_INFO};
  viewUsage.usage = usage;
  if (usage != 0) view.pNext = &viewUsage;
  view.image = image.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = format;
  view.subresourceRange = {image.aspect, 0, image.mipLevels, 0, 1};
  VkImageView handle = VK_NULL_HANDLE;
  VK_CHECK(vkCreateImageView(context_->device, &view, nullptr, &handle));
  views_.push_back(handle);
  return handle;
}

VkBufferView Arena::createTexelView(const Buffer& buffer, VkFormat format) {
  VkBufferViewCreateInfo view{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
  view.buffer = buffer.buffer;
  view.format = format;
  view.offset = 0;
  constexpr VkDeviceSize kTexelBytes = 16;
  view.range = std::min(buffer.size, context_->info.maxTexelBufferElements * kTexelBytes) /
               kTexelBytes * kTexelBytes;
  VkBufferView handle = VK_NULL_HANDLE;
  VK_CHECK(vkCreateBufferView(context_->device, &view, nullptr, &handle));
  texelViews_.push_back(handle);
  return handle;
}

void Arena::release() {
  VkDevice device = context_->device;
  for (VkBufferView v : texelViews_) vkDestroyBufferView(device, v, nullptr);
  for (VkImageView v : views_) vkDestroyImageView(device, v, nullptr);
  for (VkImage i : images_) vkDestroyImage(device, i, nullptr);
  for (VkBuffer b : buffers_) vkDestroyBuffer(device, b, nullptr);
  for (Block& b : blocks_) vkFreeMemory(device, b.memory, nullptr);  // also unmaps
  views_.clear();
  texelViews_.clear();
  images_.clear();
  buffers_.clear();
  blocks_.clear();
}

VkDeviceSize Arena::bytesAllocated() const {
  VkDeviceSize total = 0;
  for (const Block& b : blocks_) total += b.size;
  return total;
}

}  // namespace myriad::gpu
