// Edits of a scene on the GPU in place: lights (written, grown, their kinds and shadow casters
// kept on the host), instances moved, materials rewritten. Each uploads only what changed.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "render/scene_buffers.h"
#include "render/scene_upload.h"

namespace myriad::render {

using namespace scene_upload;

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
    layered[w.index] = w.material.layered() ? 1 : 0;
    textured[w.index] = hasTexture(w.material) ? 1 : 0;
  }
}

bool SceneBuffers::anyEmission() const {
  return std::find(emits.begin(), emits.end(), uint8_t{1}) != emits.end();
}

bool SceneBuffers::anyLayers() const {
  return std::find(layered.begin(), layered.end(), uint8_t{1}) != layered.end();
}

}  // namespace myriad::render
