#include "gpu_test_support.h"

namespace myriad::test {

void GpuSuite::setScene(const scene::Scene& s) {
  if (scene == 0) scene = renderer->createScene(s);
  else renderer->replaceScene(scene, s);
  lighting.takeLightingFrom(s);
}

render::Frame GpuSuite::render(render::FrameSettings f) {
  f.sun = lighting.sun;
  f.extraSuns = lighting.extraSuns;
  f.ambient = lighting.ambient;
  f.background = lighting.background;
  return renderer->render(scene, f);
}

render::Tuning& suiteTuning() {
  static render::Tuning tuning;
  return tuning;
}

GpuSuite createGpuSuite(const render::Tuning& tuning) {
  GpuSuite g;
  g.context = gpu::createContext({.validation = true, .device = ""});
  g.renderer = std::make_unique<render::Renderer>(*g.context, tuning);
  return g;
}

}  // namespace myriad::test
