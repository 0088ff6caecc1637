// One scene's texture images on the GPU, and one descriptor set (set 3) per material binding them.
// Each scene image is uploaded once per way it is read: as R8G8B8A8_SRGB where a material uses it
// as base colour or emissive (so filtering and the mip chain average linear light), as
// R8G8B8A8_UNORM where it holds data (metallic-roughness, normal, occlusion); the full mip chain is
// made on the CPU at upload (box filter; colour in linear light, re-encoded with exact rounding),
// not by blits, whose sRGB rounding is the driver's. Samplers are made once per distinct scene::Sampler
// (anisotropic where the device offers samplerAnisotropy). A slot a material leaves empty binds a
// 1x1 white image; the material's flags tell the shader which slots are real.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/resources.h"
#include "scene/scene.h"

namespace myriad::render {

class MaterialTextures {
 public:
  // Uploads `scene.images` (waiting for the upload) and writes a set per material. Throws
  // std::invalid_argument for a texture naming a missing image or an image whose bytes do not
  // match its size.
  MaterialTextures(gpu::Context& context, gpu::CommandRecorder& recorder,
                   VkDescriptorSetLayout layout, const scene::Scene& scene);
  ~MaterialTextures();
  MaterialTextures(const MaterialTextures&) = delete;
  MaterialTextures& operator=(const MaterialTextures&) = delete;

  VkDescriptorSet set(uint32_t material) const { return sets_.at(material); }
  uint64_t bytes() const { return arena_.bytesAllocated(); }

 private:
  VkSampler samplerFor(const scene::Sampler& sampler);

  gpu::Context& context_;
  gpu::Arena arena_;
  // Per scene image, then the white default last: its sRGB image's view where a colour slot reads
  // it, its UNORM image's view where a data slot does (else null).
  std::vector<VkImageView> colorViews_;
  std::vector<VkImageView> dataViews_;
  std::vector<std::pair<scene::Sampler, VkSampler>> samplers_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::vector<VkDescriptorSet> sets_;
};

}  // namespace myriad::render
