#include "render/scene_upload.h"

#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>

namespace myriad::render::scene_upload {

void transfer(gpu::Context& context, gpu::CommandRecorder& recorder,
              const std::vector<DeviceCopy>& copies, const std::vector<Upload>& uploads) {
  VkDeviceSize total = 0;
  for (const Upload& u : uploads) total += u.size;
  size_t work = copies.size();
  for (const Upload& u : uploads) work += u.size > 0 ? 1 : 0;
  if (work == 0) return;
  gpu::Arena staging(context, std::max<VkDeviceSize>(total, 16));
  gpu::Buffer buffer = staging.createBuffer(total, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                            gpu::MemoryUse::Upload);
  VkCommandBuffer cmd = gpu::beginCommands(context, recorder);
  // Earlier frames read these buffers and animation wrote the lights: they finish first.
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
  for (const DeviceCopy& c : copies) {
    if (c.size == 0) continue;
    VkBufferCopy region{0, 0, c.size};
    vkCmdCopyBuffer(cmd, c.source->buffer, c.destination->buffer, 1, &region);
  }
  if (!copies.empty()) {
    // Uploads may overwrite what the copies wrote.
    gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  }
  VkDeviceSize offset = 0;
  for (const Upload& u : uploads) {
    if (u.size == 0) continue;
    std::memcpy(static_cast<char*>(buffer.mapped) + offset, u.data, u.size);
    VkBufferCopy region{offset, u.offset, u.size};
    vkCmdCopyBuffer(cmd, buffer.buffer, u.destination->buffer, 1, &region);
    offset += u.size;
  }
  // Frames are later submissions on the same queue: vertex fetches, shader reads, animation's
  // writes and the restore copy all come after these writes.
  gpu::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  gpu::submitAndWait(context, recorder);
}

namespace {

// The dielectric's reflectance at normal incidence: KHR_materials_ior's ((ior-1)/(ior+1))^2 (0.04
// at glTF's 1.5) times KHR_materials_specular's factor.
float dielectricF0(const scene::Material& m) {
  const float r = (m.ior - 1.0f) / (m.ior + 1.0f);
  return std::min(r * r, 1.0f) * m.specular;
}

}  // namespace

bool emitsLight(const scene::Material& m) {
  return m.unlit || (m.emissiveStrength != 0.0f && m.emissive != glm::vec3(0.0f)) ||
         m.ior != 1.5f || m.specular != 1.0f;
}

bool hasTexture(const scene::Material& m) {
  for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
    if (m.texture(slot).present()) return true;
  }
  return false;
}

GpuMaterial toGpu(const scene::Material& m) {
  GpuMaterial g{};
  g.baseColor = glm::vec4(m.baseColor, m.alpha);
  g.metallicRoughness = glm::vec4(m.metallic, m.roughness, m.normalScale, m.occlusionStrength);
  g.emissive = glm::vec4(m.emissive * m.emissiveStrength, m.alphaCutoff);
  uint32_t flags = 0;
  for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
    const scene::TextureRef& t = m.texture(slot);
    if (t.present()) flags |= 1u << slot;
    // KHR_texture_transform: translation * rotation * scale, rows of the 2x3 matrix.
    const float c = std::cos(t.rotation), s = std::sin(t.rotation);
    g.uvTransform[2 * slot] = glm::vec4(c * t.scale.x, s * t.scale.y, t.offset.x, 0.0f);
    g.uvTransform[2 * slot + 1] = glm::vec4(-s * t.scale.x, c * t.scale.y, t.offset.y, 0.0f);
  }
  if (m.alphaMode == scene::AlphaMode::mask) flags |= MYRIAD_MATERIAL_ALPHA_MASK;
  if (m.alphaMode == scene::AlphaMode::blend) flags |= MYRIAD_MATERIAL_ALPHA_BLEND;
  if (m.doubleSided) flags |= MYRIAD_MATERIAL_DOUBLE_SIDED;
  if (m.unlit) flags |= MYRIAD_MATERIAL_UNLIT;
  g.flags = glm::uvec4(flags, std::bit_cast<uint32_t>(dielectricF0(m)),
                       std::bit_cast<uint32_t>(m.specular), 0);
  g.layers = glm::vec4(m.clearcoat, m.clearcoatRoughness, m.sheenRoughness, 0.0f);
  g.sheenColor = glm::vec4(m.sheenColor, 0.0f);
  return g;
}

uint64_t nextGeneration() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1);
}

}  // namespace myriad::render::scene_upload
