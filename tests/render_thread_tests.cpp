// The render thread's task queue: scene edits and frames run in the order submitted, only frames
// count against maxQueuedFrames, exceptions reach the future and the thread keeps serving, and
// gpuMemoryBytes() follows scenes created and destroyed. Vulkan with validation on.
#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "image_compare.h"
#include "render/reference.h"
#include "scene/light_generator.h"
#include "scene/primitives.h"
#include "render/render_thread.h"

using namespace myriad;

namespace {

scene::Scene floorWithBlock(glm::vec3 blockColour) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.5f), 0.0f, 0.6f});
  s.materials.push_back({"block", blockColour, 0.0f, 0.5f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(40.0f, 1.0f, 40.0f))});
  s.instances.push_back({1, 1, glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.5f, 0.0f))});
  s.lights = {{glm::vec3(1.0f, 1.0f, 1.0f), 3.0f, glm::vec3(1.0f, 0.8f, 0.6f), 5.0f, 1.0f}};
  return s;
}

render::FrameSettings settingsFor(const scene::Scene& s) {
  render::FrameSettings f;
  f.width = 48;
  f.height = 32;
  f.camera.eye = glm::vec3(0.0f, 2.5f, 4.0f);
  f.camera.target = glm::vec3(0.0f, 0.3f, 0.0f);
  f.markers = false;
  f.antialias = render::Antialias::None;  // compared with the reference, which does not anti-alias
  f.takeLightingFrom(s);
  return f;
}

using test::pixelsOver;

}  // namespace

TEST_CASE("render thread: edits and frames in order, errors to the future, frames alone limited") {
  const scene::Scene builtin = floorWithBlock(glm::vec3(0.2f, 0.8f, 0.2f));
  render::RenderThread thread({.validation = true, .device = ""}, builtin, 1);
  const render::SceneId defaultScene = thread.defaultScene();
  const uint64_t startBytes = thread.gpuMemoryBytes();
  CHECK(startBytes > 0);

  // A session's scene; an edit queued right behind it is seen by the frame queued behind that.
  auto session = std::make_shared<scene::Scene>(floorWithBlock(glm::vec3(0.2f, 0.2f, 0.9f)));
  render::SceneId id = thread.createScene(session).get();
  CHECK(id != defaultScene);
  CHECK(thread.gpuMemoryBytes() > startBytes);
  session->materials[1].baseColor = glm::vec3(0.9f, 0.1f, 0.1f);
  std::future<void> edited = thread.updateMaterials(id, {{1, session->materials[1]}});
  std::future<render::Frame> frame = thread.submit(id, settingsFor(*session));
  edited.get();
  render::Frame red = frame.get();
  std::vector<uint8_t> expected = render::renderReference(*session, settingsFor(*session));
  CHECK(pixelsOver(red.rgba, expected, 2) <= red.rgba.size() / 4 / 200);
  // The default scene is untouched by the session's edit.
  render::Frame builtinFrame = thread.submit(settingsFor(builtin)).get();
  CHECK(pixelsOver(builtinFrame.rgba, red.rgba, 10) > 20);

  // Errors reach the future; the thread goes on.
  CHECK_THROWS_AS(thread.destroyScene(9999).get(), std::invalid_argument);
  CHECK_THROWS_AS(thread.submit(9999, settingsFor(builtin)).get(), std::invalid_argument);
  CHECK_THROWS_AS(thread.updateLights(id, {5, {}}).get(), std::invalid_argument);
  render::FrameSettings tooBig = settingsFor(builtin);
  tooBig.width = thread.maxDimension() + 1;
  CHECK_THROWS_AS(thread.submit(tooBig).get(), std::invalid_argument);
  CHECK(thread.submit(id, settingsFor(*session)).get().rgba == red.rgba);

  // Only frames count against maxQueuedFrames (1 here): with the thread busy uploading scenes,
  // the first frame waits, a second may wait behind it, a third is refused; edits never are.
  scene::Scene heavy = floorWithBlock(glm::vec3(0.5f));
  scene::LightGeneration g;
  g.count = 300000;
  heavy.lights = scene::generateLights(g);
  auto heavyShared = std::make_shared<const scene::Scene>(std::move(heavy));
  std::vector<std::future<render::SceneId>> created;
  for (int i = 0; i < 4; ++i) created.push_back(thread.createScene(heavyShared));
  std::future<render::Frame> first = thread.submit(settingsFor(builtin));
  std::future<render::Frame> second = thread.submit(settingsFor(builtin));
  CHECK_THROWS_AS(thread.submit(settingsFor(builtin)), render::RenderQueueFullError);
  std::future<void> stillAccepted = thread.updateLights(id, {1, {{0, session->lights[0]}}});
  CHECK(first.get().rgba == builtinFrame.rgba);
  CHECK(second.get().rgba == builtinFrame.rgba);
  stillAccepted.get();

  // Destroying the scenes gives their memory back, visible as soon as each future is ready.
  const uint64_t withHeavy = thread.gpuMemoryBytes();
  for (auto& c : created) thread.destroyScene(c.get()).get();
  thread.destroyScene(id).get();
  MESSAGE("GPU memory: " << startBytes / 1024 << " KiB at start, " << withHeavy / 1024
                         << " KiB with 4 scenes of 300,000 lights, " << thread.gpuMemoryBytes() / 1024
                         << " KiB after destroying them");
  CHECK(withHeavy > thread.gpuMemoryBytes() + 4 * 2 * 300000 * 32);
  CHECK(thread.validationMessages() == 0);

  thread.stop();
  CHECK_THROWS_AS(thread.createScene(session), render::RenderQueueFullError);
  CHECK_THROWS_AS(thread.submit(settingsFor(builtin)), render::RenderQueueFullError);
}
