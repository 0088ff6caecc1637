// Buffers and images, allocated from arenas: every resource in an arena shares one lifetime and
// a few large vkAllocateMemory blocks, and the arena frees them all at once. Renderer state that
// changes together (the frame's targets, the scene's buffers) lives in one arena, so there is no
// per-resource bookkeeping and no hand-kept destructor list.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.h"

namespace myriad::gpu {

enum class MemoryUse {
  DeviceLocal,  // GPU-only: targets, geometry (filled through a staging copy)
  Upload,       // host-visible, coherent, mapped: CPU writes, GPU reads
  Readback,     // host-visible, cached where possible, mapped: GPU writes, CPU reads
};

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // non-null for Upload and Readback buffers
};

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkExtent2D extent{0, 0};
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
  uint32_t mipLevels = 1;
};

// The memory type a buffer of `use` (transfer destination) gets on this device, in words:
// "type 3: host-visible, host-coherent, host-cached (heap 1, 251 GiB)". For the start-up log: a
// readback that is not host-cached makes every host read of a frame slow.
std::string describeMemoryUse(Context& context, MemoryUse use);

// Large enough that a frame's targets take one or two allocations; small enough not to waste much
// on lavapipe, where "device memory" is host memory.
inline constexpr VkDeviceSize kDefaultBlockSize = 64ull << 20;

class Arena {
 public:
  // Blocks are at least `minBlockSize` (more when one resource needs more). Many small arenas
  // (one per session's scene) pass a small size so each costs about what it holds.
  explicit Arena(Context& context, VkDeviceSize minBlockSize = kDefaultBlockSize)
      : context_(&context), minBlockSize_(minBlockSize) {}
  ~Arena() { release(); }
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;

  Buffer createBuffer(VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use);
  // `mipLevels` > 1: the view covers them all. `flags`: e.g. VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT,
  // for an image viewed in two compatible formats (createView).
  Image createImage2D(VkExtent2D extent, VkFormat format, VkImageUsageFlags usage,
                      uint32_t mipLevels = 1, VkImageCreateFlags flags = 0);
  // Another view of `image` (every mip level) in `format`, destroyed with the arena; `usage`
  // non-zero: what this view is used for (a subset of the image's usage).
  VkImageView createView(const Image& image, VkFormat format, VkImageUsageFlags usage = 0);
  // A texel view of `buffer` (made with a texel-buffer usage) in `format`, a 16-byte format: all
  // of it, or its first maxTexelBufferElements texels where the device allows fewer. Destroyed
  // with the arena.
  VkBufferView createTexelView(const Buffer& buffer, VkFormat format);

  // Destroys every resource and frees every block. The caller ensures the GPU is done with them.
  void release();

  VkDeviceSize bytesAllocated() const;

 private:
  struct Block {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    uint32_t memoryType = 0;
    VkDeviceSize size = 0;
    VkDeviceSize used = 0;
    void* mapped = nullptr;
  };
  struct Placement {
    VkDeviceMemory memory;
    VkDeviceSize offset;
    void* mapped;
  };
  Placement place(const VkMemoryRequirements& requirements, MemoryUse use);

  Context* context_;
  VkDeviceSize minBlockSize_;
  std::vector<Block> blocks_;
  std::vector<VkBuffer> buffers_;
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkBufferView> texelViews_;
};

// Index of a memory type allowed by `typeBits` with all of `required` (and `preferred` if any
// type has them). Throws if none.
uint32_t findMemoryType(const VkPhysicalDeviceMemoryProperties& props, uint32_t typeBits,
                        VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred);

}  // namespace myriad::gpu
