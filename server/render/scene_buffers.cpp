#include "render/scene_buffers.h"

#include <algorithm>
#include <bit>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <stdexcept>
#include <utility>

#include "render/gpu_types.h"
#include "scene/camera.h"
#include "render/light_packing.h"
#include "scene/primitives.h"

namespace myriad::render {

namespace {

// 320 triangles: enough that the circumscribing proxy is within 3% of the sphere, so few pixels
// outside the light's reach run the fragment shader.
constexpr uint32_t kProxySubdivisions = 2;

// Scenes are many and mostly small (one per session): small blocks keep an empty scene at a few
// hundred KiB instead of the frame targets' 64 MiB blocks.
constexpr VkDeviceSize kSceneBlockSize = 1ull << 20;
constexpr VkDeviceSize kLightBlockSize = 256ull << 10;
// Light buffers start exactly full; the first growth makes room for at least this many.
constexpr uint32_t kFirstGrownLightCapacity = 64;

// Host data copied into a GPU buffer at `offset`.
struct Upload {
  const gpu::Buffer* destination;
  VkDeviceSize offset;
  const void* data;
  VkDeviceSize size;
};

// A GPU-side copy from the start of one buffer to the start of another.
struct DeviceCopy {
  const gpu::Buffer* source;
  const gpu::Buffer* destination;
  VkDeviceSize size;
};

// Runs the device copies, then every upload through one staging buffer, in one submission.
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

GpuPointLight toGpu(const scene::PointLight& l) { return packLight(l); }

// The dielectric's reflectance at normal incidence: KHR_materials_ior's ((ior-1)/(ior+1))^2 (0.04
// at glTF's 1.5) times KHR_materials_specular's factor.
float dielectricF0(const scene::Material& m) {
  const float r = (m.ior - 1.0f) / (m.ior + 1.0f);
  return std::min(r * r, 1.0f) * m.specular;
}

// Whether the material needs the emissive target: emission is factor x strength (x texture),
// zero whenever the factor or the strength is; an unlit material emits its base colour
// (material_core.glsl's withUnlit); and the target's alpha carries a dielectric F0 other than
// glTF's 0.04 (frame.glsl's loadSurfaceWithDepth).
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
  return g;
}

// Element writes in index order, the last write of an index winning, merged into runs of
// consecutive indices: one copy region per run ("generate 100,000 lights" is one region).
template <typename Gpu, typename Write, typename Convert>
std::vector<Upload> elementUploads(const std::vector<Write>& writes, const gpu::Buffer& destination,
                                   std::vector<Gpu>& staged, Convert convert) {
  std::vector<size_t> order(writes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return writes[a].index < writes[b].index; });
  std::vector<uint32_t> indices;
  staged.clear();
  staged.reserve(order.size());
  for (size_t k = 0; k < order.size(); ++k) {
    const Write& w = writes[order[k]];
    if (k + 1 < order.size() && writes[order[k + 1]].index == w.index) continue;  // a later one wins
    indices.push_back(w.index);
    staged.push_back(convert(w));
  }
  std::vector<Upload> uploads;
  for (size_t first = 0; first < indices.size();) {
    size_t end = first + 1;
    while (end < indices.size() && indices[end] == indices[end - 1] + 1) ++end;
    uploads.push_back({&destination, VkDeviceSize(indices[first]) * sizeof(Gpu), &staged[first],
                       VkDeviceSize(end - first) * sizeof(Gpu)});
    first = end;
  }
  return uploads;
}

}  // namespace

MeshDetail MeshDetail::of(const FrameSettings& settings) {
  MeshDetail detail;
  // Gribb and Hartmann's planes from the rows of the view-projection (Vulkan's depth 0..1: the
  // near plane is row 2 alone). Normalised so that a sphere's radius compares in world units.
  const float aspect = float(settings.width) / float(std::max(settings.height, 1u));
  const glm::mat4 m = glm::transpose(scene::projectionMatrix(settings.camera, aspect) *
                                     scene::viewMatrix(settings.camera));
  const glm::vec4 planes[6] = {m[3] + m[0], m[3] - m[0], m[3] + m[1],
                               m[3] - m[1], m[2],        m[3] - m[2]};
  detail.cull = true;
  for (int i = 0; i < 6; ++i) {
    const float length = glm::length(glm::vec3(planes[i]));
    if (!(length > 0.0f) || !std::isfinite(length)) detail.cull = false;
    detail.planes[size_t(i)] = planes[i] / length;
  }
  if (!(settings.geometryErrorPixels > 0.0f)) return detail;
  detail.maxErrorPixels = settings.geometryErrorPixels;
  detail.eye = settings.camera.eye;
  const float halfFov = 0.5f * glm::radians(std::clamp(settings.camera.fovYDegrees, 1.0f, 179.0f));
  detail.pixelsAtUnitDistance = 0.5f * float(settings.height) / std::tan(halfFov);
  detail.nearPlane = std::max(settings.camera.nearPlane, 1e-6f);
  return detail;
}

MeshRange MeshDetail::range(const SceneBuffers& scene, const DrawItem& draw) const {
  if (cull) {
    for (const glm::vec4& plane : planes) {
      if (glm::dot(glm::vec3(plane), draw.centre) + plane.w < -draw.radius) {
        return {draw.mesh.firstIndex, 0, draw.mesh.vertexOffset};  // wholly outside: not drawn
      }
    }
  }
  if (!(maxErrorPixels > 0.0f) || draw.meshIndex >= scene.lods.size()) return draw.mesh;
  const MeshLods& lods = scene.lods[draw.meshIndex];
  if (lods.ranges.empty()) return draw.mesh;
  // The nearest any of the draw's points can be to the eye (at least the near plane): where a
  // mesh unit covers the most pixels.
  const float nearest = std::max(glm::length(draw.centre - eye) - draw.radius, nearPlane);
  const float pixelsPerUnit = draw.unitScale * pixelsAtUnitDistance / nearest;
  const int lod = scene::coarsestLodWithin(lods.errors, pixelsPerUnit, maxErrorPixels);
  if (lod < 0) return draw.mesh;
  MeshRange coarser = lods.ranges[static_cast<size_t>(lod)];
  coarser.vertexOffset = draw.mesh.vertexOffset;  // a posed instance's own region
  return coarser;
}

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

namespace {

uint64_t nextGeneration() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1);
}

}  // namespace

GpuInstance SceneBuffers::gpuInstance(const glm::mat4& transform, uint32_t material, uint32_t object,
                                      uint32_t semantic) {
  GpuInstance g;
  g.model = transform;
  g.normalMatrix = glm::transpose(glm::inverse(transform));
  g.material = glm::uvec4(material, object, semantic, 0);
  return g;
}

void SceneBuffers::place(DrawItem& draw, const glm::mat4& transform) const {
  const glm::mat3 axes(transform);
  draw.unitScale = std::max({glm::length(axes[0]), glm::length(axes[1]), glm::length(axes[2])});
  draw.centre = glm::vec3(transform * glm::vec4(meshCentres_[draw.meshIndex], 1.0f));
  draw.radius = meshRadii_[draw.meshIndex] * draw.unitScale;
}

SceneBuffers::SceneBuffers(gpu::Context& context, gpu::CommandRecorder& recorder,
                           const scene::Scene& scene, VkDescriptorSetLayout materialSetLayout)
    : context(context), generation(nextGeneration()), arena(context, kSceneBlockSize),
      lightArena(std::make_unique<gpu::Arena>(context, kLightBlockSize)) {
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
  std::vector<glm::vec3> centres;  // of each mesh's bounds
  std::vector<float> radii;        // half their diagonal
  for (const scene::Mesh& mesh : scene.meshes) {
    ranges.push_back(append(mesh));
    // Coarser versions: more indices over the same vertices.
    MeshLods meshLods;
    for (const scene::MeshLod& lod : mesh.lods) {
      const bool valid = std::all_of(lod.indices.begin(), lod.indices.end(),
                                     [&](uint32_t i) { return i < mesh.vertices.size(); });
      if (!valid || lod.indices.empty()) break;
      MeshRange range = ranges.back();
      range.firstIndex = static_cast<uint32_t>(allIndices.size());
      range.indexCount = static_cast<uint32_t>(lod.indices.size());
      allIndices.insert(allIndices.end(), lod.indices.begin(), lod.indices.end());
      meshLods.ranges.push_back(range);
      meshLods.errors.push_back(lod.error);
    }
    lods.push_back(std::move(meshLods));
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t index : mesh.indices) {
      if (index >= mesh.vertices.size()) continue;
      lo = glm::min(lo, mesh.vertices[index].position);
      hi = glm::max(hi, mesh.vertices[index].position);
    }
    centres.push_back(lo.x <= hi.x ? 0.5f * (lo + hi) : glm::vec3(0.0f));
    radii.push_back(lo.x <= hi.x ? 0.5f * glm::length(hi - lo) : 0.0f);
  }

  scene::Mesh proxy = scene::makeIcosphere(kProxySubdivisions);
  float scale = circumscribeScale(proxy);
  for (scene::Vertex& v : proxy.vertices) v.position *= scale;
  lightProxy = append(proxy);
  // Skinned and morphed instances: a region each after the meshes (render/skinning.h).
  posing = planPosing(context, scene, ranges, allVertices);
  if (posing && allVertices.size() * sizeof(scene::Vertex) > context.info.maxStorageBufferRange) {
    // The pre-pass reads and writes them through one storage-buffer range.
    throw std::invalid_argument(
        "the scene's vertices with its posed copies (" +
        std::to_string(allVertices.size() * sizeof(scene::Vertex)) +
        " bytes) are more than this device's storage buffers reach (" +
        std::to_string(context.info.maxStorageBufferRange) + ")");
  }

  std::vector<GpuInstance> gpuInstances;
  meshCentres_ = centres;
  meshRadii_ = radii;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& instance = scene.instances[i];
    if (instance.mesh >= scene.meshes.size() || instance.material >= scene.materials.size()) {
      throw std::invalid_argument("instance " + std::to_string(i) + " refers to a missing mesh or material");
    }
    gpuInstances.push_back(
        gpuInstance(instance.transform, instance.material, instance.object, instance.semantic));
    instanceMaterial_.push_back(instance.material);
    instanceMesh_.push_back(instance.mesh);
    instanceObject_.push_back(instance.object);
    instanceSemantic_.push_back(instance.semantic);
    if (ranges[instance.mesh].indexCount > 0) {
      DrawItem draw{ranges[instance.mesh], i, instance.material};
      draw.meshIndex = instance.mesh;
      draws.push_back(draw);
      place(draws.back(), instance.transform);
    }
  }
  instanceCount = static_cast<uint32_t>(gpuInstances.size());
  // One descriptor set bind per material in the G-buffer pass.
  std::stable_sort(draws.begin(), draws.end(),
                   [](const DrawItem& a, const DrawItem& b) { return a.material < b.material; });
  drawOfInstance_.assign(instanceCount, UINT32_MAX);
  for (uint32_t d = 0; d < draws.size(); ++d) drawOfInstance_[draws[d].instance] = d;
  if (posing) {
    // A posed instance's draws read its own region, whichever version of the mesh they draw.
    for (const ScenePosing::Posed& p : posing->posed) {
      if (drawOfInstance_[p.instance] == UINT32_MAX) continue;
      DrawItem& draw = draws[drawOfInstance_[p.instance]];
      draw.mesh.vertexOffset = static_cast<int32_t>(p.firstPosed);
      // Culled by where the rest pose (node tree, default weights) puts it, not the bind space.
      const glm::vec4 sphere = posing->posedSphere(p, posing->restPose);
      draw.centre = glm::vec3(scene.instances[p.instance].transform * glm::vec4(glm::vec3(sphere), 1.0f));
      draw.radius = sphere.w * draw.unitScale;
    }
  }
  for (const scene::Material& m : scene.materials) {
    doubleSided.push_back(m.doubleSided ? 1 : 0);
    blend.push_back(m.alphaMode == scene::AlphaMode::blend ? 1 : 0);
    alphaTest.push_back(m.alphaMode == scene::AlphaMode::mask ? 1 : 0);
    emits.push_back(emitsLight(m) ? 1 : 0);
    textured.push_back(hasTexture(m) ? 1 : 0);
  }
  textures = std::make_unique<MaterialTextures>(context, recorder, materialSetLayout, scene);
  std::vector<GpuMaterial> gpuMaterials;
  for (const scene::Material& m : scene.materials) gpuMaterials.push_back(toGpu(m));
  materialCount = static_cast<uint32_t>(gpuMaterials.size());
  std::vector<GpuPointLight> gpuLights;
  gpuLights.reserve(scene.lights.size());
  for (const scene::PointLight& l : scene.lights) gpuLights.push_back(toGpu(l));
  lightCount = static_cast<uint32_t>(gpuLights.size());
  for (uint32_t i = 0; i < lightCount; ++i) {
    if (scene.lights[i].castsShadows) shadowCasters.push_back({i, gpuLights[i]});
  }
  setLightKinds(lightCount, nullptr, &gpuLights);
  bounds = scene.bounds();
  restBounds_ = bounds;
  if (posing) bounds = poseBounds();  // grown by where the rest pose puts the posed draws

  auto bytes = [](const auto& v) { return VkDeviceSize(v.size() * sizeof(v[0])); };
  const VkBufferUsageFlags dst = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  // Storage too: the G-buffer rasterised in compute reads them (render/visibility.h).
  vertices = arena.createBuffer(bytes(allVertices), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT |
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | dst,
                                gpu::MemoryUse::DeviceLocal);
  indices = arena.createBuffer(bytes(allIndices), VK_BUFFER_USAGE_INDEX_BUFFER_BIT |
                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | dst,
                               gpu::MemoryUse::DeviceLocal);
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | dst;
  // A copy source too: a motion frame's previous placements start as a copy (render/skinning.h).
  instances = arena.createBuffer(bytes(gpuInstances), storage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                 gpu::MemoryUse::DeviceLocal);
  const uint64_t materialTexelCount = uint64_t(gpuMaterials.size()) * MYRIAD_MATERIAL_TEXELS;
  if (materialTexelCount > context.info.maxTexelBufferElements) {
    throw std::invalid_argument(std::to_string(gpuMaterials.size()) +
                                " materials are more than this device's texel buffers hold (" +
                                std::to_string(context.info.maxTexelBufferElements /
                                               MYRIAD_MATERIAL_TEXELS) + ")");
  }
  materials = arena.createBuffer(bytes(gpuMaterials),
                                 storage | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT,
                                 gpu::MemoryUse::DeviceLocal);
  materialTexels = arena.createTexelView(materials, VK_FORMAT_R32G32B32A32_UINT);
  allocateLights(lightCount);
  transfer(context, recorder, {},
           {{&vertices, 0, allVertices.data(), bytes(allVertices)},
            {&indices, 0, allIndices.data(), bytes(allIndices)},
            {&instances, 0, gpuInstances.data(), bytes(gpuInstances)},
            {&materials, 0, gpuMaterials.data(), bytes(gpuMaterials)},
            {&lights, 0, gpuLights.data(), bytes(gpuLights)},
            {&lightOrigins, 0, gpuLights.data(), bytes(gpuLights)}});
  if (posing) uploadPosing(*posing, arena, recorder);
}

void SceneBuffers::allocateLights(uint32_t capacity) {
  auto next = std::make_unique<gpu::Arena>(context, kLightBlockSize);
  const VkDeviceSize size = VkDeviceSize(capacity) * sizeof(GpuPointLight);
  // Both are copy sources and destinations: growth copies them, restore copies origins to lights.
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  gpu::Buffer nextLights = next->createBuffer(
      size, usage | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT, gpu::MemoryUse::DeviceLocal);
  const VkBufferView nextTexels = next->createTexelView(nextLights, VK_FORMAT_R32G32B32A32_SFLOAT);
  gpu::Buffer nextOrigins = next->createBuffer(size, usage, gpu::MemoryUse::DeviceLocal);
  lightArena = std::move(next);
  lights = nextLights;
  lightTexels = nextTexels;
  lightOrigins = nextOrigins;
  lightCapacity = capacity;
}

void SceneBuffers::updateLights(gpu::CommandRecorder& recorder, const LightUpdate& update) {
  const uint32_t count = update.count;
  const uint64_t deviceMost = context.info.maxStorageBufferRange / sizeof(GpuPointLight);
  if (count > deviceMost) {
    throw std::invalid_argument(std::to_string(count) + " lights are more than this device's " +
                                std::to_string(deviceMost) + " (maxStorageBufferRange)");
  }
  // Every new slot must be written, or it would shade with whatever the buffer held.
  std::vector<bool> newWritten(count > lightCount ? count - lightCount : 0, false);
  for (const LightWrite& w : update.writes) {
    if (w.index >= count) {
      throw std::invalid_argument("light write at index " + std::to_string(w.index) +
                                  " is past the new light count " + std::to_string(count));
    }
    if (w.index >= lightCount) newWritten[w.index - lightCount] = true;
  }
  for (size_t i = 0; i < newWritten.size(); ++i) {
    if (!newWritten[i]) {
      throw std::invalid_argument("new light " + std::to_string(lightCount + i) +
                                  " (of " + std::to_string(count) + ") is not written");
    }
  }

  std::vector<GpuPointLight> staged;
  auto convert = [](const LightWrite& w) { return toGpu(w.light); };
  if (count <= lightCapacity) {
    std::vector<Upload> uploads = elementUploads<GpuPointLight>(update.writes, lights, staged, convert);
    size_t n = uploads.size();
    for (size_t i = 0; i < n; ++i) {
      Upload origin = uploads[i];
      origin.destination = &lightOrigins;
      uploads.push_back(origin);
    }
    transfer(context, recorder, {}, uploads);
    setLightKinds(count, &update, nullptr);
    lightCount = count;
    updateShadowCasters(update);
    return;
  }

  // Grow by doubling: appending lights one request at a time costs O(n) copies in all.
  uint64_t grown = std::max<uint64_t>({count, uint64_t(lightCapacity) * 2, kFirstGrownLightCapacity});
  uint32_t capacity = static_cast<uint32_t>(std::min<uint64_t>(grown, deviceMost));
  std::unique_ptr<gpu::Arena> oldArena = std::move(lightArena);
  const gpu::Buffer oldLights = lights, oldOrigins = lightOrigins;
  const VkBufferView oldTexels = lightTexels;
  const uint32_t oldCapacity = lightCapacity;
  auto restore = [&] {
    lightArena = std::move(oldArena);
    lights = oldLights;
    lightTexels = oldTexels;
    lightOrigins = oldOrigins;
    lightCapacity = oldCapacity;
  };
  try {
    allocateLights(capacity);
    const VkDeviceSize kept = VkDeviceSize(std::min(lightCount, count)) * sizeof(GpuPointLight);
    std::vector<Upload> uploads = elementUploads<GpuPointLight>(update.writes, lights, staged, convert);
    size_t n = uploads.size();
    for (size_t i = 0; i < n; ++i) {
      Upload origin = uploads[i];
      origin.destination = &lightOrigins;
      uploads.push_back(origin);
    }
    transfer(context, recorder, {{&oldLights, &lights, kept}, {&oldOrigins, &lightOrigins, kept}},
             uploads);
  } catch (...) {
    restore();  // the old buffers were only read: the scene is as it was
    throw;
  }
  setLightKinds(count, &update, nullptr);
  lightCount = count;
  updateShadowCasters(update);
}

namespace {

uint8_t kindOf(const GpuPointLight& light) {
  uint8_t kind = light.radianceFalloff.w < 0.0f ? 4 : 2;  // inverse-square : window
  if (light.cone.z > MYRIAD_POINT_LIGHT_COS_OUTER) kind |= 1;
  return kind;
}

}  // namespace

// Before lightCount takes `count`: drops the kinds of lights past it, then applies the writes
// in order (the last write to an index wins, as on the GPU), or takes every light of `all`.
void SceneBuffers::setLightKinds(uint32_t count, const LightUpdate* update,
                                 const std::vector<GpuPointLight>* all) {
  auto count3 = [&](uint8_t kind, int sign) {
    for (auto [bit, counter] : {std::pair{1, &spotLights_}, std::pair{2, &windowLights_},
                                std::pair{4, &inverseSquareLights_}}) {
      if ((kind & bit) == 0) continue;
      if (sign > 0) {
        ++*counter;
      } else {
        --*counter;
      }
    }
  };
  for (size_t i = count; i < lightKinds_.size(); ++i) count3(lightKinds_[i], -1);
  lightKinds_.resize(count, 0);
  if (all) {
    for (uint32_t i = 0; i < count; ++i) {
      lightKinds_[i] = kindOf((*all)[i]);
      count3(lightKinds_[i], 1);
    }
  }
  if (update) {
    for (const LightWrite& w : update->writes) {
      count3(lightKinds_[w.index], -1);
      lightKinds_[w.index] = kindOf(toGpu(w.light));
      count3(lightKinds_[w.index], 1);
    }
  }
}

uint32_t SceneBuffers::lightFeatures() const {
  return (spotLights_ > 0 ? MYRIAD_FEATURE_SPOT_LIGHTS : 0u) |
         (windowLights_ > 0 ? MYRIAD_FEATURE_WINDOW_FALLOFF : 0u) |
         (inverseSquareLights_ > 0 ? MYRIAD_FEATURE_INVERSE_SQUARE : 0u);
}

// Merges the update into the sorted caster list: O(casters + writes log writes), so an update
// that adds a million asking lights at once costs one pass, not a million insertions.
void SceneBuffers::updateShadowCasters(const LightUpdate& update) {
  std::vector<const LightWrite*> writes;
  writes.reserve(update.writes.size());
  for (const LightWrite& w : update.writes) writes.push_back(&w);
  // The last write to an index wins, as on the GPU (uploads run in order).
  std::stable_sort(writes.begin(), writes.end(),
                   [](const LightWrite* a, const LightWrite* b) { return a->index < b->index; });
  std::vector<ShadowCaster> next;
  next.reserve(shadowCasters.size());
  size_t c = 0;
  for (size_t w = 0; w <= writes.size(); ++w) {
    const uint32_t upTo = w < writes.size() ? writes[w]->index : lightCount;
    for (; c < shadowCasters.size() && shadowCasters[c].index < upTo; ++c) next.push_back(shadowCasters[c]);
    if (w == writes.size()) break;
    if (w + 1 < writes.size() && writes[w + 1]->index == upTo) continue;  // a later write wins
    while (c < shadowCasters.size() && shadowCasters[c].index == upTo) ++c;  // replaced
    if (writes[w]->light.castsShadows) next.push_back({upTo, toGpu(writes[w]->light)});
  }
  shadowCasters = std::move(next);  // lights at or past the new count fell off the end
}

void SceneBuffers::updateInstances(gpu::CommandRecorder& recorder, const InstanceUpdate& update) {
  for (const InstanceWrite& w : update.writes) {
    if (w.index >= instanceCount) {
      throw std::invalid_argument("instance " + std::to_string(w.index) + " is past the scene's " +
                                  std::to_string(instanceCount) + " instances");
    }
    const float det = glm::determinant(glm::mat3(w.transform));
    bool finite = std::isfinite(det) && det != 0.0f;
    for (int c = 0; c < 4 && finite; ++c) {
      for (int r = 0; r < 4; ++r) finite = finite && std::isfinite(w.transform[c][r]);
    }
    if (!finite) {
      throw std::invalid_argument("instance " + std::to_string(w.index) +
                                  "'s transform is not finite and invertible");
    }
  }
  std::vector<GpuInstance> staged;
  std::vector<Upload> uploads =
      elementUploads<GpuInstance>(update.writes, instances, staged, [&](const InstanceWrite& w) {
        return gpuInstance(w.transform, instanceMaterial_[w.index], instanceObject_[w.index],
                           instanceSemantic_[w.index]);
      });
  transfer(context, recorder, {}, uploads);
  Moves moved{generation, {}};
  for (const InstanceWrite& w : update.writes) {
    if (drawOfInstance_[w.index] == UINT32_MAX) continue;
    DrawItem& draw = draws[drawOfInstance_[w.index]];
    moved.spheres.emplace_back(draw.centre, draw.radius);
    place(draw, w.transform);
    moved.spheres.emplace_back(draw.centre, draw.radius);
  }
  if (moves.size() == kMoveHistory) moves.erase(moves.begin());
  moves.push_back(std::move(moved));
  if (posing && !posing->posed.empty()) {
    for (const InstanceWrite& w : update.writes) {
      const uint32_t k = posing->posedOf[w.index];
      if (k == MYRIAD_SKIN_NONE) continue;
      posing->transforms[k] = w.transform;
      if (drawOfInstance_[w.index] == UINT32_MAX) continue;
      // Its sphere is the deformed mesh's, not the rest mesh's place() gave it.
      DrawItem& draw = draws[drawOfInstance_[w.index]];
      const glm::vec4 sphere = posing->posedSphere(
          posing->posed[k], posing->lastPose ? posing->poseContent(*posing->lastPose) : posing->restPose);
      draw.centre = glm::vec3(w.transform * glm::vec4(glm::vec3(sphere), 1.0f));
      draw.radius = sphere.w * draw.unitScale;
      if (!moves.empty()) moves.back().spheres.emplace_back(draw.centre, draw.radius);
    }
  }
  bounds = update.bounds;
  generation = nextGeneration();
}

void SceneBuffers::geometryMoved(std::vector<glm::vec4> spheres) {
  if (moves.size() == kMoveHistory) moves.erase(moves.begin());
  moves.push_back({generation, std::move(spheres)});
  generation = nextGeneration();
}

std::optional<std::vector<glm::vec4>> SceneBuffers::movedSince(uint64_t earlier,
                                                                 size_t limit) const {
  std::vector<glm::vec4> spheres;
  for (auto it = moves.rbegin(); it != moves.rend(); ++it) {
    spheres.insert(spheres.end(), it->spheres.begin(), it->spheres.end());
    if (spheres.size() > limit) return std::nullopt;
    if (it->from == earlier) return spheres;
  }
  return std::nullopt;
}

void SceneBuffers::updateMaterials(gpu::CommandRecorder& recorder,
                                   const std::vector<MaterialWrite>& writes) {
  for (const MaterialWrite& w : writes) {
    if (w.index >= materialCount) {
      throw std::invalid_argument("material " + std::to_string(w.index) + " is past the scene's " +
                                  std::to_string(materialCount) + " materials");
    }
  }
  std::vector<GpuMaterial> staged;
  std::vector<Upload> uploads = elementUploads<GpuMaterial>(
      writes, materials, staged, [](const MaterialWrite& w) { return toGpu(w.material); });
  transfer(context, recorder, {}, uploads);
  for (const MaterialWrite& w : writes) {
    doubleSided[w.index] = w.material.doubleSided ? 1 : 0;
    blend[w.index] = w.material.alphaMode == scene::AlphaMode::blend ? 1 : 0;
    alphaTest[w.index] = w.material.alphaMode == scene::AlphaMode::mask ? 1 : 0;
    emits[w.index] = emitsLight(w.material) ? 1 : 0;
    textured[w.index] = hasTexture(w.material) ? 1 : 0;
  }
}

bool SceneBuffers::anyEmission() const {
  return std::find(emits.begin(), emits.end(), uint8_t{1}) != emits.end();
}

}  // namespace myriad::render
