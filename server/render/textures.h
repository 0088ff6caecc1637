// One scene's texture images on the GPU, and one descriptor set (set 3) per material binding them.
// Each scene image is uploaded once, as an RGBA8 image with a mutable format viewed two ways:
// sRGB where a material uses it as base colour or emissive, UNORM where it holds data
// (metallic-roughness, normal, occlusion); its mip chain is generated on the GPU with blits where
// the format allows (else it has one level). Samplers are made once per distinct scene::Sampler
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
  std::vector<gpu::Image> images_;  // scene images, then the white default last
  std::vector<VkImageView> srgbViews_;
  std::vector<std::pair<scene::Sampler, VkSampler>> samplers_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::vector<VkDescriptorSet> sets_;
};

}  // namespace myriad::render
