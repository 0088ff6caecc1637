#include "scene/scene.h"

namespace myriad::scene {

Bounds Scene::bounds() const {
  Bounds result;
  for (const Instance& instance : instances) {
    // An instance naming a mesh that does not exist contributes nothing rather than faulting:
    // scenes are edited over the API and may be briefly inconsistent.
    if (instance.mesh >= meshes.size()) continue;
    const Bounds b = transformedBounds(meshes[instance.mesh], instance.transform);
    if (!b.empty()) {
      result.extend(b.min);
      result.extend(b.max);
    }
  }
  return result;
}

Bounds transformedBounds(const Mesh& mesh, const glm::mat4& transform) {
  Bounds result;
  for (const Vertex& vertex : mesh.vertices) {
    result.extend(glm::vec3(transform * glm::vec4(vertex.position, 1.0f)));
  }
  return result;
}

int coarsestLodWithin(std::span<const float> lodErrors, float pixelsPerUnit,
                      float maxErrorPixels) {
  int chosen = -1;
  if (!(maxErrorPixels > 0.0f) || !(pixelsPerUnit >= 0.0f)) return chosen;
  for (size_t i = 0; i < lodErrors.size(); ++i) {
    if (lodErrors[i] * pixelsPerUnit <= maxErrorPixels) chosen = static_cast<int>(i);
  }
  return chosen;
}

}  // namespace myriad::scene
