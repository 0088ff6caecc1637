#include "render/textures.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <stdexcept>
#include <string>

#include "gpu/vk_check.h"
#include "shared_types.h"

namespace myriad::render {

namespace {

// Texture storage: small scenes stay small, and a 2048^2 image with its mips (21 MiB) gets a block
// of its own.
constexpr VkDeviceSize kTextureBlockSize = 4ull << 20;
constexpr VkFormat kDataFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_SRGB;
constexpr float kMostAnisotropy = 16.0f;

// Whether mips of `format` can be made by linear blits from level to level on this device.
bool canBlitMips(const gpu::Context& context, VkFormat format) {
  VkFormatProperties properties;
  vkGetPhysicalDeviceFormatProperties(context.physicalDevice, format, &properties);
  const VkFormatFeatureFlags needed = VK_FORMAT_FEATURE_BLIT_SRC_BIT | VK_FORMAT_FEATURE_BLIT_DST_BIT |
                                      VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
  return (properties.optimalTilingFeatures & needed) == needed;
}

// Copies `rgba` into level 0 of `image`, blits each level from the one above, and leaves every
// level READ_ONLY_OPTIMAL for fragment shaders. One submission, waited for.
void upload(gpu::Context& context, gpu::CommandRecorder& recorder, const gpu::Image& image,
            const uint8_t* rgba, VkDeviceSize size) {
  gpu::Arena staging(context, std::max<VkDeviceSize>(size, 16));
  gpu::Buffer buffer =
      staging.createBuffer(size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, gpu::MemoryUse::Upload);
  std::memcpy(buffer.mapped, rgba, size);
  VkCommandBuffer cmd = gpu::beginCommands(context, recorder);
  const uint32_t levels = image.mipLevels;
  gpu::barrier(cmd, std::array{gpu::ImageTransition{
                        &image, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                        VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT,
                        VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, levels}});
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {image.extent.width, image.extent.height, 1};
  vkCmdCopyBufferToImage(cmd, buffer.buffer, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                         &region);
  int32_t width = int32_t(image.extent.width), height = int32_t(image.extent.height);
  for (uint32_t level = 1; level < levels; ++level) {
    gpu::barrier(cmd, std::array{gpu::ImageTransition{
                          &image, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                          VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                          VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, level - 1, 1}});
    const int32_t nextWidth = std::max(width / 2, 1), nextHeight = std::max(height / 2, 1);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, 1};
    blit.srcOffsets[1] = {width, height, 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
    blit.dstOffsets[1] = {nextWidth, nextHeight, 1};
    vkCmdBlitImage(cmd, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image.image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    width = nextWidth;
    height = nextHeight;
  }
  const VkPipelineStageFlags2 transfer = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  const VkPipelineStageFlags2 fragment = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  if (levels > 1) {
    gpu::barrier(cmd, std::array{
                          gpu::ImageTransition{&image, transfer, VK_ACCESS_2_TRANSFER_READ_BIT,
                                               fragment, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                               VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                               VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL, 0, levels - 1},
                          gpu::ImageTransition{&image, transfer, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                               fragment, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                               VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL, levels - 1, 1}});
  } else {
    gpu::barrier(cmd, std::array{gpu::ImageTransition{
                          &image, transfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, fragment,
                          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                          VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL}});
  }
  gpu::submitAndWait(context, recorder);
}

VkSamplerAddressMode addressOf(scene::Sampler::Wrap wrap) {
  switch (wrap) {
    case scene::Sampler::Wrap::clampToEdge: return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    case scene::Sampler::Wrap::mirroredRepeat: return VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT;
    case scene::Sampler::Wrap::repeat: break;
  }
  return VK_SAMPLER_ADDRESS_MODE_REPEAT;
}

VkFilter filterOf(scene::Sampler::Filter filter) {
  return filter == scene::Sampler::Filter::nearest ? VK_FILTER_NEAREST : VK_FILTER_LINEAR;
}

// Which slots read colour (sRGB view) rather than data (UNORM view).
bool isColorSlot(size_t slot) {
  return slot == MYRIAD_BINDING_TEXTURE_BASE_COLOR || slot == MYRIAD_BINDING_TEXTURE_EMISSIVE;
}

}  // namespace

MaterialTextures::MaterialTextures(gpu::Context& context, gpu::CommandRecorder& recorder,
                                   VkDescriptorSetLayout layout, const scene::Scene& scene)
    : context_(context), arena_(context, kTextureBlockSize) {
  static_assert(scene::Material::kTextureSlots == MYRIAD_TEXTURE_SLOTS);
  // Which way each image is read: as colour (base colour, emissive: an sRGB image, whose blits
  // average in linear light, so its mips keep the image's brightness) or as data (UNORM, averaged
  // as stored). An image read both ways is uploaded twice, once each.
  const size_t count = scene.images.size();
  std::vector<uint8_t> asColor(count + 1, 0), asData(count + 1, 0);
  for (const scene::Material& m : scene.materials) {
    for (uint32_t slot = 0; slot < MYRIAD_TEXTURE_SLOTS; ++slot) {
      const scene::TextureRef& ref = m.texture(slot);
      if (!ref.present()) continue;
      if (ref.image >= count) {
        throw std::invalid_argument("a material uses image " + std::to_string(ref.image) +
                                    ", which the scene lacks");
      }
      (isColorSlot(slot) ? asColor : asData)[ref.image] = 1;
    }
  }
  asColor[count] = asData[count] = 1;  // the white default serves every slot
  scene::Image white;
  white.width = white.height = 1;
  white.rgba = {255, 255, 255, 255};
  colorViews_.assign(count + 1, VK_NULL_HANDLE);
  dataViews_.assign(count + 1, VK_NULL_HANDLE);
  auto add = [&](const scene::Image& source, VkFormat format) {
    if (source.width == 0 || source.height == 0 ||
        source.rgba.size() != size_t(source.width) * source.height * 4) {
      throw std::invalid_argument("image '" + source.name + "' does not hold its size in pixels");
    }
    const uint32_t levels = canBlitMips(context, format)
                                ? uint32_t(std::bit_width(std::max(source.width, source.height)))
                                : 1;
    gpu::Image image = arena_.createImage2D(
        {source.width, source.height}, format,
        VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
            (levels > 1 ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0),
        levels);
    upload(context, recorder, image, source.rgba.data(), source.rgba.size());
    return image.view;
  };
  for (size_t i = 0; i <= count; ++i) {
    const scene::Image& source = i < count ? scene.images[i] : white;
    if (asColor[i]) colorViews_[i] = add(source, kColorFormat);
    if (asData[i]) dataViews_[i] = add(source, kDataFormat);
  }
  const uint32_t whiteIndex = uint32_t(count);

  const uint32_t setCount = std::max<uint32_t>(1, uint32_t(scene.materials.size()));
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                            setCount * MYRIAD_TEXTURE_SLOTS};
  VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = setCount;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(context.device, &poolInfo, nullptr, &pool_));
  std::vector<VkDescriptorSetLayout> layouts(setCount, layout);
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = pool_;
  alloc.descriptorSetCount = setCount;
  alloc.pSetLayouts = layouts.data();
  sets_.resize(setCount);
  VK_CHECK(vkAllocateDescriptorSets(context.device, &alloc, sets_.data()));

  for (uint32_t m = 0; m < setCount; ++m) {
    const scene::Material material = m < scene.materials.size() ? scene.materials[m]
                                                                : scene::Material{};
    VkDescriptorImageInfo infos[MYRIAD_TEXTURE_SLOTS];
    VkWriteDescriptorSet writes[MYRIAD_TEXTURE_SLOTS];
    for (uint32_t slot = 0; slot < MYRIAD_TEXTURE_SLOTS; ++slot) {
      const scene::TextureRef& ref = material.texture(slot);
      const uint32_t image = ref.present() ? ref.image : whiteIndex;
      infos[slot] = {samplerFor(ref.present() ? ref.sampler : scene::Sampler{}),
                     isColorSlot(slot) ? colorViews_[image] : dataViews_[image],
                     VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL};
      writes[slot] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[slot].dstSet = sets_[m];
      writes[slot].dstBinding = slot;
      writes[slot].descriptorCount = 1;
      writes[slot].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      writes[slot].pImageInfo = &infos[slot];
    }
    vkUpdateDescriptorSets(context.device, MYRIAD_TEXTURE_SLOTS, writes, 0, nullptr);
  }
}

MaterialTextures::~MaterialTextures() {
  if (pool_) vkDestroyDescriptorPool(context_.device, pool_, nullptr);
  for (auto& [description, sampler] : samplers_) vkDestroySampler(context_.device, sampler, nullptr);
}

VkSampler MaterialTextures::samplerFor(const scene::Sampler& s) {
  for (const auto& [description, sampler] : samplers_) {
    if (description == s) return sampler;
  }
  VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  info.magFilter = filterOf(s.magFilter);
  info.minFilter = filterOf(s.minFilter);
  info.mipmapMode = s.mipmapFilter == scene::Sampler::Filter::nearest
                        ? VK_SAMPLER_MIPMAP_MODE_NEAREST
                        : VK_SAMPLER_MIPMAP_MODE_LINEAR;
  info.addressModeU = addressOf(s.wrapS);
  info.addressModeV = addressOf(s.wrapT);
  info.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  info.minLod = 0.0f;
  // Without mipmaps the minification filter reads level 0 only.
  info.maxLod = s.mipmaps ? VK_LOD_CLAMP_NONE : 0.0f;
  // Not on a CPU implementation: lavapipe offers samplerAnisotropy, but its software anisotropic
  // filter made DamagedHelmet's G-buffer pass at 64x64 take 285 s instead of 0.8 s.
  if (!context_.info.isCpu && context_.maxAnisotropy > 1.0f && s.mipmaps && s.minFilter == scene::Sampler::Filter::linear) {
    info.anisotropyEnable = VK_TRUE;
    info.maxAnisotropy = std::min(context_.maxAnisotropy, kMostAnisotropy);
  }
  VkSampler sampler = VK_NULL_HANDLE;
  VK_CHECK(vkCreateSampler(context_.device, &info, nullptr, &sampler));
  samplers_.emplace_back(s, sampler);
  return sampler;
}

}  // namespace myriad::render
