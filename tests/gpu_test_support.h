// The in-process GPU suites' device: a validating Vulkan context on whatever device is present
// (lavapipe in CI) and a renderer on it, with one scene a suite may replace test by test.
#pragma once

#include <memory>

#include "gpu/context.h"
#include "render/renderer.h"
#include "scene/scene.h"

namespace myriad::test {

struct GpuSuite {
  std::unique_ptr<gpu::Context> context;
  std::unique_ptr<render::Renderer> renderer;
  render::SceneId scene = 0;
  render::FrameSettings lighting;  // the current scene's sun, ambient and background

  // The suite's one scene, replaced by each test.
  void setScene(const scene::Scene& s);
  // Renders it lit by its own sun, ambient and background.
  render::Frame render(render::FrameSettings f);
};

// The knobs every suite's renderer is made with unless a test names its own: defaults, or what
// the binary's --tune flags set (tests/gpu_main.cpp).
render::Tuning& suiteTuning();

// A context with validation on and a renderer made with `tuning`; a suite keeps it in a
// function-local static, as creating instances per test would dominate the run time.
GpuSuite createGpuSuite(const render::Tuning& tuning = suiteTuning());

}  // namespace myriad::test
