// The render thread's task queue: a scene's edits and frames run in the order submitted, only frames
// count against maxQueuedFrames, exceptions reach the future and the thread keeps serving, and
// gpuMemoryBytes() follows scenes created and destroyed. Vulkan with validation on.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

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
  // (Scene creations have a queue of their own: the frames above may finish before them.)
  std::vector<render::SceneId> heavyIds;
  for (auto& c : created) heavyIds.push_back(c.get());
  const uint64_t withHeavy = thread.gpuMemoryBytes();
  for (render::SceneId heavyId : heavyIds) thread.destroyScene(heavyId).get();
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

TEST_CASE("render thread: scenes take turns, so a backlog of one delays another's frame by one") {
  const scene::Scene builtin = floorWithBlock(glm::vec3(0.2f, 0.8f, 0.2f));
  render::RenderThread thread({.validation = true, .device = ""}, builtin, 8);
  auto session = std::make_shared<scene::Scene>(floorWithBlock(glm::vec3(0.2f, 0.2f, 0.9f)));
  const render::SceneId busy = thread.createScene(session).get();

  // Keep the thread busy (a scene upload) while the frames queue: four of one scene, then one of
  // another. In one FIFO the last would finish fifth; taking turns, it finishes second.
  scene::Scene upload = floorWithBlock(glm::vec3(0.5f));
  scene::LightGeneration g;
  g.count = 300000;
  upload.lights = scene::generateLights(g);
  std::future<render::SceneId> created =
      thread.createScene(std::make_shared<const scene::Scene>(std::move(upload)));
  std::vector<std::future<render::Frame>> frames;
  for (int i = 0; i < 4; ++i) frames.push_back(thread.submit(busy, settingsFor(*session)));
  frames.push_back(thread.submit(settingsFor(builtin)));
  std::vector<size_t> order;  // indices of `frames` as they finish
  std::vector<bool> seen(frames.size(), false);
  while (order.size() < frames.size()) {
    for (size_t i = 0; i < frames.size(); ++i) {
      if (!seen[i] && frames[i].wait_for(std::chrono::microseconds(50)) == std::future_status::ready) {
        seen[i] = true;
        order.push_back(i);
      }
    }
  }
  const size_t otherPosition = size_t(std::find(order.begin(), order.end(), 4) - order.begin());
  MESSAGE("the other scene's frame finished at position " << otherPosition + 1 << " of 5");
  CHECK(otherPosition <= 2);  // second, allowing for the polling
  for (auto& f : frames) CHECK(f.get().width == 48);
  thread.destroyScene(created.get()).get();

  // destroyScene drops the scene's frames still waiting: their futures fail, nothing renders.
  // (Behind another 300,000-light upload, so that the frame is still waiting.)
  scene::Scene second = floorWithBlock(glm::vec3(0.5f));
  second.lights = scene::generateLights(g);
  std::future<render::SceneId> again =
      thread.createScene(std::make_shared<const scene::Scene>(std::move(second)));
  std::future<render::Frame> dropped = thread.submit(busy, settingsFor(*session));
  std::future<void> destroyed = thread.destroyScene(busy);
  destroyed.get();
  CHECK_THROWS_AS(dropped.get(), std::invalid_argument);
  thread.destroyScene(again.get()).get();

  // A frame given up before it starts (a stream that ended with a frame submitted ahead) is not
  // rendered; one not given up is.
  auto giveUp = std::make_shared<std::atomic<bool>>(true);
  CHECK_THROWS_AS(
      thread.submit(thread.defaultScene(), settingsFor(builtin), render::FrameSource::Stream, giveUp)
          .get(),
      render::FrameDroppedError);
  auto keep = std::make_shared<std::atomic<bool>>(false);
  CHECK(thread.submit(thread.defaultScene(), settingsFor(builtin), render::FrameSource::Stream, keep)
            .get()
            .width == 48);
  CHECK(thread.validationMessages() == 0);
  thread.stop();
}

TEST_CASE("render thread: a split frame given up stops at its next part") {
  const scene::Scene builtin = floorWithBlock(glm::vec3(0.2f, 0.8f, 0.2f));
  render::RenderThread thread({.validation = true, .device = ""}, builtin, 4);
  // 100,000 light volumes: more than a frame splits before any light was measured; each part
  // draws a few thousand of them, and the whole frame takes seconds on lavapipe.
  scene::Scene heavy = floorWithBlock(glm::vec3(0.5f));
  scene::LightGeneration g;
  g.count = 100000;
  g.bounds = {glm::vec3(-3.0f, 0.1f, -3.0f), glm::vec3(3.0f, 1.5f, 3.0f)};
  heavy.lights = scene::generateLights(g);
  const render::SceneId id =
      thread.createScene(std::make_shared<const scene::Scene>(std::move(heavy))).get();
  render::FrameSettings settings = settingsFor(builtin);
  settings.technique = render::Technique::Volumes;
  auto giveUp = std::make_shared<std::atomic<bool>>(false);
  std::future<render::Frame> frame =
      thread.submit(id, settings, render::FrameSource::Request, giveUp);
  // Once it renders (its first part is quick), other frames still pass it...
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK(thread.submit(settingsFor(builtin)).get().width == 48);
  REQUIRE(frame.wait_for(std::chrono::seconds(0)) != std::future_status::ready);
  // ...and giving it up ends it at its next part, not after all of its lights.
  const auto start = std::chrono::steady_clock::now();
  *giveUp = true;
  std::string message;
  try {
    frame.get();
  } catch (const render::FrameDroppedError& e) {
    message = e.what();
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                              start).count();
  MESSAGE("a split frame given up ended " << ms << " ms later: " << message);
  CHECK(message == "the frame was given up while it rendered");
  CHECK(ms < 3000.0);
  thread.destroyScene(id).get();
  CHECK(thread.validationMessages() == 0);
  thread.stop();
}
