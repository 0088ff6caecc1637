// How many pixels of an image an object's surfaces cover with nothing in front of them: the
// "total" pixel count of a label (GET .../labels), beside the visible count the instance-id
// frame gives. Rasterised on the CPU, the GPU's way: a pixel is covered when its centre lies
// inside a triangle (edges shared by two triangles count once: the top-left rule), after clipping
// to the near and far planes. Both faces count (a closed mesh shows one either way).
//
// Plain geometry: no Vulkan, no HTTP. Cost: O(triangles + the pixels their boxes span), bounded by
// the caller's triangle budget.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace myriad::scene {

// A pinhole image as a frame's X-Myriad-Intrinsics and X-Myriad-Pose give it (OpenCV axes:
// x right, y down, z forward; pixel (0, 0)'s top-left corner at u = v = 0).
struct PinholeView {
  glm::mat4 cameraFromWorld{1.0f};
  float fx = 1.0f, fy = 1.0f, cx = 0.0f, cy = 0.0f;
  float near = 0.05f, far = 200.0f;
  uint32_t width = 0, height = 0;
};

class CoverageCounter {
 public:
  explicit CoverageCounter(const PinholeView& view);

  // Rasterises `mesh` placed by `transform` into the current object's coverage. Returns false,
  // adding nothing, when it would pass `triangleBudget` (counted over every add()).
  bool add(const Mesh& mesh, const glm::mat4& transform);
  // The pixels covered by what was added since the last take(), which starts the next object.
  uint64_t take();

  uint64_t triangleBudget = uint64_t(1) << 24;
  uint64_t trianglesSeen() const { return triangles_; }

 private:
  void rasterise(glm::vec2 a, glm::vec2 b, glm::vec2 c);

  PinholeView view_;
  std::vector<uint8_t> covered_;  // width * height, 1 where the current object covers
  glm::ivec4 dirty_{0};           // x0, y0, x1, y1 of what the current object set
  uint64_t count_ = 0;
  uint64_t triangles_ = 0;
};

}  // namespace myriad::scene
