#include "render/scene_buffers.h"

#include <cstring>
#include <stdexcept>

#include "render/gpu_types.h"
#include "scene/primitives.h"

namespace myriad::render {

namespace {

// 320 triangles: enough that the circumscribing proxy is within 3% of the sphere, so few pixels
// outside the light's reach run the fragment shader.
constexpr uint32_t kProxySubdivisions = 2;

struct Upload {
  gpu::Buffer* destination;
  const void* data;
  VkDeviceSize size;
};

// Copies every upload through one staging buffer and one submission.
void uploadAll(gpu::Context& context, gpu::CommandRecorder& recorder,
               const std::vector<Upload>& uploads) {
  VkDeviceSize total = 0;
  for (const Upload& u : uploads) total += u.size;
  gpu::Arena staging(context);
  gpu::Buffer buffer = staging.createBuffer(total, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                            gpu::MemoryUse::Upload);
  VkCommandBuffer cmd = gpu::beginCommands(context, recorder);
  VkDeviceSize offset = 0;
  for (const Upload& u : uploads) {
    if (u.size == 0) continue;
    std::memcpy(static_cast<char*>(buffer.mapped) + offset, u.data, u.size);
    VkBufferCopy region{offset, 0, u.size};
    vkCmdCopyBuffer(cmd, buffer.buffer, u.destination->buffer, 1, &region);
    offset += u.size;
  }
  // Frames are later submissions on the same queue; this barrier makes the copies visible to
  // their vertex fetches and shader reads.
  VkMemoryBarrier2 barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  barrier.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  barrier.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  barrier.dstStageMask = VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;  // animation, culling, lighting
  barrier.dstAccessMask = VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT |
                          VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
  VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dependency.memoryBarrierCount = 1;
  dependency.pMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dependency);
  gpu::submitAndWait(context, recorder);
}

}  // namespace

float circumscribeScale(const scene::Mesh& mesh) {
  float minDistance = 1.0f;
  for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    glm::vec3 a = mesh.vertices[mesh.indices[i]].position;
    glm::vec3 b = mesh.vertices[mesh.indices[i + 1]].position;
    glm::vec3 c = mesh.vertices[mesh.indices[i + 2]].position;
    glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
    minDistance = std::min(minDistance, std::abs(glm::dot(n, a)));
  }
  return 1.0f / minDistance;
}

SceneBuffers::SceneBuffers(gpu::Context& context, gpu::CommandRecorder& recorder,
                           const scene::Scene& scene)
    : arena(context) {
  std::vector<scene::Vertex> allVertices;
  std::vector<uint32_t> allIndices;
  std::vector<MeshRange> ranges;
  auto append = [&](const scene::Mesh& mesh) {
    MeshRange range;
    range.firstIndex = static_cast<uint32_t>(allIndices.size());
    range.indexCount = static_cast<uint32_t>(mesh.indices.size());
    range.vertexOffset = static_cast<int32_t>(allVertices.size());
    allVertices.insert(allVertices.end(), mesh.vertices.begin(), mesh.vertices.end());
    allIndices.insert(allIndices.end(), mesh.indices.begin(), mesh.indices.end());
    return range;
  };
  for (const scene::Mesh& mesh : scene.meshes) ranges.push_back(append(mesh));

  scene::Mesh proxy = scene::makeIcosphere(kProxySubdivisions);
  float scale = circumscribeScale(proxy);
  for (scene::Vertex& v : proxy.vertices) v.position *= scale;
  lightProxy = append(proxy);

  std::vector<GpuInstance> gpuInstances;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& instance = scene.instances[i];
    if (instance.mesh >= scene.meshes.size() || instance.material >= scene.materials.size()) {
      throw std::invalid_argument("instance " + std::to_string(i) + " refers to a missing mesh or material");
    }
    GpuInstance g;
    g.model = instance.transform;
    g.normalMatrix = glm::transpose(glm::inverse(instance.transform));
    g.material = glm::uvec4(instance.material, 0, 0, 0);
    gpuInstances.push_back(g);
    if (ranges[instance.mesh].indexCount > 0) draws.push_back({ranges[instance.mesh], i});
  }
  std::vector<GpuMaterial> gpuMaterials;
  for (const scene::Material& m : scene.materials) {
    gpuMaterials.push_back({glm::vec4(m.baseColor, 1.0f), glm::vec4(m.metallic, m.roughness, 0, 0)});
  }
  std::vector<GpuPointLight> gpuLights;
  gpuLights.reserve(scene.lights.size());
  for (const scene::PointLight& l : scene.lights) {
    gpuLights.push_back({glm::vec4(l.position, l.radius), glm::vec4(l.color * l.intensity, l.falloff)});
  }
  lightCount = static_cast<uint32_t>(gpuLights.size());
  bounds = scene.bounds();

  auto bytes = [](const auto& v) { return VkDeviceSize(v.size() * sizeof(v[0])); };
  const VkBufferUsageFlags dst = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  vertices = arena.createBuffer(bytes(allVertices), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | dst,
                                gpu::MemoryUse::DeviceLocal);
  indices = arena.createBuffer(bytes(allIndices), VK_BUFFER_USAGE_INDEX_BUFFER_BIT | dst,
                               gpu::MemoryUse::DeviceLocal);
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | dst;
  instances = arena.createBuffer(bytes(gpuInstances), storage, gpu::MemoryUse::DeviceLocal);
  materials = arena.createBuffer(bytes(gpuMaterials), storage, gpu::MemoryUse::DeviceLocal);
  lights = arena.createBuffer(bytes(gpuLights), storage, gpu::MemoryUse::DeviceLocal);
  lightOrigins = arena.createBuffer(bytes(gpuLights), storage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                    gpu::MemoryUse::DeviceLocal);
  uploadAll(context, recorder,
            {{&vertices, allVertices.data(), bytes(allVertices)},
             {&indices, allIndices.data(), bytes(allIndices)},
             {&instances, gpuInstances.data(), bytes(gpuInstances)},
             {&materials, gpuMaterials.data(), bytes(gpuMaterials)},
             {&lights, gpuLights.data(), bytes(gpuLights)},
             {&lightOrigins, gpuLights.data(), bytes(gpuLights)}});
}

}  // namespace myriad::render
