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
#include "render/scene_upload.h"
#include "scene/primitives.h"

namespace myriad::render {

using namespace scene_upload;

namespace {

// 320 triangles: enough that the circumscribing proxy is within 3% of the sphere, so few pixels
// outside the light's reach run the fragment shader.
constexpr uint32_t kProxySubdivisions = 2;

// Scenes are many and mostly small (one per session): small blocks keep an empty scene at a few
// hundred KiB instead of the frame targets' 64 MiB blocks.
constexpr VkDeviceSize kSceneBlockSize = 1ull << 20;

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
    layered.push_back(m.layered() ? 1 : 0);
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

}  // namespace myriad::render
