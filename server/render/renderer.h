// The deferred renderer: one frame function, passes top to bottom (see renderer.cpp).
// Not thread-safe: exactly one thread (the render thread) calls it.
#pragma once

#include <memory>

#include "gpu/context.h"
#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::render {

class Renderer {
 public:
  explicit Renderer(gpu::Context& context);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Uploads the scene's meshes, materials and lights; later frames draw it.
  void setScene(const scene::Scene& scene);

  // Renders one frame of the current scene and reads it back.
  Frame render(const FrameSettings& settings);

  // The largest width or height render() accepts on this device.
  uint32_t maxDimension() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace myriad::render
