// SessionScene without HTTP or Vulkan: the light ids/slots invariant (checked against a mirror
// that applies each returned LightUpdate the way the renderer does), scene adoption, settings,
// camera and materials, and that an edit that throws changes nothing.
#include <doctest/doctest.h>

#include <algorithm>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/animation.h"
#include "scene/builtin_scene.h"
#include "service/problem.h"
#include "service/session_scene.h"

namespace myriad {
namespace {

using service::Adoption;
using service::Clock;
using service::ProblemError;
using service::SessionScene;
using nlohmann::json;

scene::PointLight light(float x, float intensity = 1.0f) {
  scene::PointLight l;
  l.position = glm::vec3(x, 1.0f, 0.0f);
  l.radius = 2.0f;
  l.color = glm::vec3(1.0f, 0.5f, 0.25f);
  l.intensity = intensity;
  l.falloff = 1.0f;
  return l;
}

bool same(const scene::PointLight& a, const scene::PointLight& b) {
  return a.position == b.position && a.radius == b.radius && a.color == b.color &&
         a.intensity == b.intensity && a.falloff == b.falloff;
}

// The GPU side as render::Renderer::updateLights defines it: after an update the array has
// `count` lights, each write lands at its index, every new index must be written and no write
// may be at or past `count`.
struct GpuMirror {
  std::vector<scene::PointLight> lights;

  void apply(const render::LightUpdate& update) {
    const size_t before = lights.size();
    std::set<uint32_t> written;
    for (const render::LightWrite& w : update.writes) {
      REQUIRE(w.index < update.count);
      written.insert(w.index);
    }
    for (size_t i = before; i < update.count; ++i) REQUIRE(written.contains(uint32_t(i)));
    lights.resize(update.count);
    for (const render::LightWrite& w : update.writes) lights[w.index] = w.light;
  }
};

// Every slot's light equals the mirror's, every id maps back to its slot, ids are unique.
void checkConsistent(const SessionScene& scene, const GpuMirror& gpu) {
  REQUIRE(gpu.lights.size() == scene.lightCount());
  std::set<uint64_t> ids;
  for (uint32_t slot = 0; slot < scene.lightCount(); ++slot) {
    CHECK(same(scene.lightAt(slot), gpu.lights[slot]));
    const uint64_t id = scene.idAt(slot);
    CHECK(ids.insert(id).second);
    CHECK(scene.slotOf(std::to_string(id)) == slot);
  }
}

ProblemError problemOf(auto&& edit) {
  try {
    edit();
  } catch (const ProblemError& e) {
    return e;
  }
  FAIL("expected a ProblemError");
  return ProblemError(service::Problem{});
}

std::shared_ptr<scene::Scene> model(size_t lights, size_t materials) {
  auto s = std::make_shared<scene::Scene>();
  for (size_t i = 0; i < lights; ++i) s->lights.push_back(light(float(i), 5.0f));
  for (size_t i = 0; i < materials; ++i) {
    scene::Material m;
    m.name = std::to_string(i);
    m.baseColor = glm::vec3(0.5f);
    s->materials.push_back(m);
  }
  s->camera.eye = glm::vec3(3.0f, 2.0f, 1.0f);
  s->camera.target = glm::vec3(0.0f);
  s->sun.intensity = 7.0f;
  s->ambient = glm::vec3(0.25f);
  return s;
}

}  // namespace

TEST_CASE("session scene: added lights get fresh ids in dense slots, and the update writes them") {
  SessionScene scene(100, {});
  GpuMirror gpu;
  std::vector<uint64_t> ids;
  const std::vector<scene::PointLight> three = {light(0), light(1), light(2)};
  render::LightUpdate update = scene.addLights(three, &ids);
  CHECK(update.count == 3);
  CHECK(update.writes.size() == 3);
  CHECK(ids == std::vector<uint64_t>{1, 2, 3});
  gpu.apply(update);
  checkConsistent(scene, gpu);

  // A second batch writes only the new slots.
  ids.clear();
  update = scene.addLights(std::vector<scene::PointLight>{light(3)}, &ids);
  CHECK(update.count == 4);
  REQUIRE(update.writes.size() == 1);
  CHECK(update.writes[0].index == 3);
  CHECK(ids == std::vector<uint64_t>{4});
  gpu.apply(update);
  checkConsistent(scene, gpu);
}

TEST_CASE("session scene: removing a light moves the last one into its slot; ids are never reused") {
  SessionScene scene(100, {});
  GpuMirror gpu;
  gpu.apply(scene.addLights(std::vector<scene::PointLight>{light(0), light(1), light(2), light(3)}));

  // Remove id 2 (slot 1): id 4 (slot 3) takes slot 1; one write, count 3.
  render::LightUpdate update = scene.removeLight(scene.slotOf("2"));
  CHECK(update.count == 3);
  REQUIRE(update.writes.size() == 1);
  CHECK(update.writes[0].index == 1);
  CHECK(same(update.writes[0].light, light(3)));
  gpu.apply(update);
  checkConsistent(scene, gpu);
  CHECK(scene.idAt(1) == 4);
  ProblemError gone = problemOf([&] { (void)scene.slotOf("2"); });
  CHECK(gone.problem().status == 404);
  CHECK(gone.problem().detail == "The session has no light \"2\" (deleted, or never created).");

  // Removing the last slot writes nothing.
  update = scene.removeLight(scene.slotOf("3"));
  CHECK(update.count == 2);
  CHECK(update.writes.empty());
  gpu.apply(update);
  checkConsistent(scene, gpu);

  // New lights continue after the highest id ever given.
  std::vector<uint64_t> ids;
  gpu.apply(scene.addLights(std::vector<scene::PointLight>{light(9)}, &ids));
  CHECK(ids == std::vector<uint64_t>{5});
  checkConsistent(scene, gpu);
}

TEST_CASE("session scene: a restored session's lights take back the ids they had") {
  SessionScene scene(100, {});
  scene.addLights(std::vector<scene::PointLight>{light(0), light(1), light(2)});
  // What a state file holds for lights that were 7, 4 and 9, the next id 12.
  CHECK_FALSE(scene.restoreLightIds({7, 4}, 12));     // another count
  CHECK_FALSE(scene.restoreLightIds({7, 4, 7}, 12));  // an id twice
  CHECK_FALSE(scene.restoreLightIds({7, 4, 12}, 12)); // not below next
  CHECK(scene.idAt(0) == 1);                          // unchanged by the refusals
  REQUIRE(scene.restoreLightIds({7, 4, 9}, 12));
  CHECK(scene.slotOf("4") == 1);
  CHECK(problemOf([&] { (void)scene.slotOf("1"); }).problem().status == 404);
  std::vector<uint64_t> ids;
  scene.addLights(std::vector<scene::PointLight>{light(3)}, &ids);
  CHECK(ids == std::vector<uint64_t>{12});
  scene.removeLight(scene.slotOf("7"));  // the last (12) moves into slot 0
  CHECK(scene.idAt(0) == 12);
}

TEST_CASE("session scene: light ids that are not numbers, or not lights, are 404") {
  SessionScene scene(10, {});
  scene.addLights(std::vector<scene::PointLight>{light(0)});
  for (std::string text : {"", "abc", "1x", "-1", "0", "2", "99999999999999999999999"}) {
    CAPTURE(text);
    CHECK(problemOf([&] { (void)scene.slotOf(text); }).problem().status == 404);
  }
  CHECK(scene.slotOf("1") == 0);
}

TEST_CASE("session scene: a patch changes only the members it names, in one write") {
  SessionScene scene(10, {});
  GpuMirror gpu;
  gpu.apply(scene.addLights(std::vector<scene::PointLight>{light(0), light(1)}));
  protocol::LightPatch patch;
  patch.intensity = 42.0;
  patch.position = protocol::Vec3{5, 6, 7};
  render::LightUpdate update = scene.patchLight(1, patch);
  CHECK(update.count == 2);
  REQUIRE(update.writes.size() == 1);
  CHECK(update.writes[0].index == 1);
  gpu.apply(update);
  checkConsistent(scene, gpu);
  const scene::PointLight& patched = scene.lightAt(1);
  CHECK(patched.intensity == 42.0f);
  CHECK(patched.position == glm::vec3(5, 6, 7));
  CHECK(patched.radius == light(1).radius);
  CHECK(patched.color == light(1).color);
  CHECK(same(scene.lightAt(0), light(0)));
}

TEST_CASE("session scene: the light limit is 413 maxLightsPerSession and leaves the lights as they were") {
  SessionScene scene(3, {});
  scene.addLights(std::vector<scene::PointLight>{light(0), light(1)});
  ProblemError tooMany =
      problemOf([&] { scene.addLights(std::vector<scene::PointLight>{light(2), light(3)}); });
  CHECK(tooMany.problem().status == 413);
  CHECK(tooMany.problem().limit == "maxLightsPerSession");
  CHECK(tooMany.problem().detail ==
        "This would leave the session with 4 lights; a session holds at most 3.");
  CHECK(scene.lightCount() == 2);
  CHECK(problemOf([&] { scene.replaceLights(std::vector<scene::PointLight>(4, light(0))); })
            .problem()
            .status == 413);
  CHECK(scene.lightCount() == 2);
  CHECK(scene.slotOf("2") == 1);

  // Replacing gives every light a fresh id; clearing empties.
  std::vector<scene::PointLight> replacement = {light(7), light(8), light(9)};
  render::LightUpdate update = scene.replaceLights(replacement);
  CHECK(update.count == 3);
  CHECK(update.writes.size() == 3);
  CHECK(scene.idAt(0) == 3);
  CHECK(problemOf([&] { (void)scene.slotOf("1"); }).problem().status == 404);
  update = scene.clearLights();
  CHECK(update.count == 0);
  CHECK(update.writes.empty());
  CHECK(scene.lightCount() == 0);
}

TEST_CASE("session scene: random edits keep CPU lights, ids, slots and the GPU mirror in step") {
  SessionScene scene(64, {});
  GpuMirror gpu;
  std::mt19937 random(12345);
  std::vector<uint64_t> live;  // ids the scene should have
  uint64_t highest = 0;
  for (int step = 0; step < 2000; ++step) {
    const int op = std::uniform_int_distribution<int>(0, 9)(random);
    if (op < 4 && scene.lightCount() < 60) {
      const size_t n = std::uniform_int_distribution<size_t>(1, 4)(random);
      std::vector<scene::PointLight> batch;
      for (size_t i = 0; i < n; ++i) batch.push_back(light(float(step), float(i)));
      std::vector<uint64_t> ids;
      gpu.apply(scene.addLights(batch, &ids));
      for (uint64_t id : ids) {
        CHECK(id > highest);
        highest = id;
        live.push_back(id);
      }
    } else if (op < 7 && !live.empty()) {
      const size_t pick = std::uniform_int_distribution<size_t>(0, live.size() - 1)(random);
      gpu.apply(scene.removeLight(scene.slotOf(std::to_string(live[pick]))));
      live.erase(live.begin() + long(pick));
    } else if (op < 9 && !live.empty()) {
      const size_t pick = std::uniform_int_distribution<size_t>(0, live.size() - 1)(random);
      protocol::LightPatch patch;
      patch.radius = 1.0 + step % 7;
      gpu.apply(scene.patchLight(scene.slotOf(std::to_string(live[pick])), patch));
    } else if (op == 9 && step % 50 == 0) {
      gpu.apply(scene.clearLights());
      live.clear();
    }
    REQUIRE(scene.lightCount() == live.size());
    checkConsistent(scene, gpu);
  }
}

TEST_CASE("session scene: adopting a model, with its lights and lighting or keeping the session's") {
  render::SceneSettings defaults;
  defaults.technique = render::Technique::Tiled;
  SessionScene scene(5, defaults);

  // A new session: everything from the model.
  std::shared_ptr<const scene::Scene> upload = scene.adopt(
      model(2, 3), "library:a.glb", Adoption{.lights = Adoption::Lights::model, .lightingFromModel = true});
  CHECK(upload->lights.size() == 2);
  CHECK(scene.lightCount() == 2);
  CHECK(scene.idAt(0) == 1);
  CHECK(scene.model().source == "library:a.glb");
  CHECK(scene.model().materials == 3);
  CHECK(scene.materials().size() == 3);
  CHECK(scene.camera().eye == glm::vec3(3.0f, 2.0f, 1.0f));
  CHECK(scene.settings().sun.intensity == 7.0f);
  CHECK(scene.settings().ambient == glm::vec3(0.25f));
  CHECK(scene.settings().technique == render::Technique::Tiled);

  // Another model, keeping the session's lights and lighting: the upload carries them.
  scene.addLights(std::vector<scene::PointLight>{light(9)});
  auto second = model(4, 1);
  second->sun.intensity = 1.0f;
  upload = scene.adopt(second, "upload:b.obj", Adoption{});
  REQUIRE(upload->lights.size() == 3);
  CHECK(same(upload->lights[2], light(9)));
  CHECK(scene.lightCount() == 3);
  CHECK(scene.slotOf("3") == 2);
  CHECK(scene.materials().size() == 1);
  CHECK(scene.model().source == "upload:b.obj");
  CHECK(scene.settings().sun.intensity == 7.0f);

  // Taking the model's lights renumbers them after the highest id given.
  upload = scene.adopt(model(4, 1), "upload:c.obj", Adoption{.lights = Adoption::Lights::model});
  CHECK(scene.lightCount() == 4);
  CHECK(scene.idAt(0) == 4);
  CHECK(problemOf([&] { (void)scene.slotOf("1"); }).problem().status == 404);

  // A model with more lights than the session may hold: 413, and nothing changes.
  ProblemError tooMany = problemOf(
      [&] { scene.adopt(model(6, 9), "upload:d.obj", Adoption{.lights = Adoption::Lights::model}); });
  CHECK(tooMany.problem().status == 413);
  CHECK(tooMany.problem().detail == "The model brings 6 lights; a session holds at most 5.");
  CHECK(scene.model().source == "upload:c.obj");
  CHECK(scene.materials().size() == 1);
  CHECK(scene.lightCount() == 4);
}

TEST_CASE("session scene: settings patches, checked; animation clock; the frame a session shows") {
  SessionScene scene(5, {});
  scene.adopt(model(0, 1), "builtin:default", Adoption{.lights = Adoption::Lights::model, .lightingFromModel = true});
  const Clock::time_point t0 = Clock::now();

  protocol::SettingsPatch bad;
  bad.exposure = 3.0;
  bad.sun = protocol::SunPatch{protocol::Vec3{0, 0, 0}, std::nullopt, std::nullopt};
  ProblemError zero = problemOf([&] { scene.patchSettings(bad, t0); });
  CHECK(zero.problem().status == 400);
  CHECK(zero.problem().pointer == "/sun/direction");
  CHECK(scene.settings().exposure == 1.0f);  // nothing of the failed patch applied

  protocol::SettingsPatch unknown;
  unknown.technique = "raytraced";
  CHECK(problemOf([&] { scene.patchSettings(unknown, t0); }).problem().pointer == "/technique");

  protocol::SettingsPatch patch;
  patch.sun = protocol::SunPatch{protocol::Vec3{0, -2, 0}, std::nullopt, std::nullopt};
  patch.exposure = 2.0;
  patch.technique = "volumes";
  patch.markers = false;
  scene.patchSettings(patch, t0);
  CHECK(scene.settings().sun.direction == glm::vec3(0, -1, 0));  // normalized
  CHECK(scene.settings().exposure == 2.0f);
  CHECK(scene.settings().technique == render::Technique::Volumes);
  CHECK_FALSE(scene.settings().markers);
  CHECK(scene.animationSeconds(t0 + std::chrono::seconds(5)) == 0.0);

  // Animation on at t0: the clock starts there; a patch that keeps it on does not restart it.
  protocol::SettingsPatch animate;
  animate.animate = true;
  scene.patchSettings(animate, t0);
  scene.patchSettings(animate, t0 + std::chrono::seconds(1));
  CHECK(scene.animationSeconds(t0 + std::chrono::seconds(3)) == doctest::Approx(3.0));

  // A frame: the request's own choices, the session's camera and settings, the clock's time.
  render::FrameSettings request;
  request.width = 320;
  request.height = 200;
  request.target = render::Target::Depth;
  request.exposure = 9.0f;  // not the request's to choose: the session's wins
  render::FrameSettings frame = scene.frameSettings(request, std::nullopt, t0 + std::chrono::seconds(2));
  CHECK(frame.width == 320);
  CHECK(frame.target == render::Target::Depth);
  CHECK(frame.exposure == 2.0f);
  CHECK(frame.technique == render::Technique::Volumes);
  CHECK(frame.camera.eye == scene.camera().eye);
  CHECK(frame.animate);
  CHECK(frame.time == doctest::Approx(2.0));
  // An explicit time wins over the clock.
  CHECK(scene.frameSettings(request, 0.5, t0).time == 0.5);

  // Not animating: time 0, unless the request names one (then the lights are shown there).
  animate.animate = false;
  scene.patchSettings(animate, t0);
  frame = scene.frameSettings(request, std::nullopt, t0 + std::chrono::seconds(2));
  CHECK_FALSE(frame.animate);
  CHECK(frame.time == 0.0);
  frame = scene.frameSettings(request, 1.5, t0);
  CHECK(frame.animate);
  CHECK(frame.time == 1.5);
}

TEST_CASE("session scene: camera edits are checked and a failed one changes nothing") {
  SessionScene scene(5, {});
  scene.adopt(model(0, 1), "builtin:default", Adoption{});
  const scene::Camera before = scene.camera();
  protocol::CameraPatch farBehind;
  farBehind.near = 10.0;
  farBehind.far = 1.0;
  ProblemError far = problemOf([&] { scene.patchCamera(farBehind); });
  CHECK(far.problem().status == 400);
  CHECK(far.problem().pointer == "/far");
  CHECK(scene.camera().nearPlane == before.nearPlane);

  protocol::CameraPatch onEye;
  onEye.target = protocol::Vec3{3, 2, 1};  // the model's eye
  CHECK(problemOf([&] { scene.patchCamera(onEye); }).problem().pointer == "/target");

  protocol::CameraPatch fov;
  fov.fovY = 35.0;
  CHECK(scene.patchCamera(fov).fovYDegrees == 35.0f);
  CHECK(scene.camera().eye == before.eye);
}

TEST_CASE("session scene: materials by id, 404 past the model's, patches in one write") {
  SessionScene scene(5, {});
  scene.adopt(model(0, 2), "builtin:default", Adoption{});
  for (std::string text : {"2", "x", "", "-1", "4294967296"}) {
    CAPTURE(text);
    CHECK(problemOf([&] { (void)scene.materialId(text); }).problem().status == 404);
  }
  CHECK(problemOf([&] { (void)scene.materialId("2"); }).problem().detail ==
        "The session's model has no material \"2\" (it has 2, ids from 0).");
  protocol::MaterialPatch patch;
  patch.roughness = 0.25;
  render::MaterialWrite write = scene.patchMaterial(scene.materialId("1"), patch);
  CHECK(write.index == 1);
  CHECK(write.material.roughness == 0.25f);
  CHECK(write.material.baseColor == glm::vec3(0.5f));
  CHECK(scene.materials()[1].roughness == 0.25f);
  CHECK(scene.materials()[0].roughness == scene::Material{}.roughness);
}


TEST_CASE("session scene: generated lights are fitted to a new model until an edit; ?lights= overrides") {
  SessionScene scene(1000, {});
  // A new session on a scene whose 40 lights were generated (the built-in scene's).
  auto first = model(40, 1);
  scene.adopt(first, "builtin:default",
              Adoption{.lights = Adoption::Lights::model, .recipe = service::LightRecipe{40, 9}});
  REQUIRE(scene.lightRecipe().has_value());

  // A model 100 m away and 50 m wide: the lights are made again around it, same count and seed.
  auto far = model(0, 1);
  scene::Mesh mesh;
  mesh.vertices = {{glm::vec3(100.0f, 0.0f, 0.0f)}, {glm::vec3(150.0f, 50.0f, 50.0f)}, {glm::vec3(150.0f, 0.0f, 0.0f)}};
  mesh.indices = {0, 1, 2};
  far->meshes.push_back(mesh);
  far->instances.push_back({0, 0, glm::mat4(1.0f)});
  std::shared_ptr<const scene::Scene> upload = scene.adopt(far, "upload:far.obj", Adoption{.lights = Adoption::Lights::automatic});
  REQUIRE(scene.lightCount() == 40);
  REQUIRE(upload->lights.size() == 40);
  const scene::Bounds bounds = scene.model().bounds;
  const float margin = glm::length(bounds.size());
  for (uint32_t slot = 0; slot < scene.lightCount(); ++slot) {
    const glm::vec3 p = scene.lightAt(slot).position;
    CHECK(glm::all(glm::greaterThanEqual(p, bounds.min - margin)));
    CHECK(glm::all(glm::lessThanEqual(p, bounds.max + margin)));
    CHECK(same(upload->lights[slot], scene.lightAt(slot)));
    CHECK(scene.lightAt(slot).radius > 1.0f);  // sized to a 50 m model, not to the first one
  }
  CHECK(scene.idAt(0) == 41);  // new lights, new ids
  const std::vector<scene::PointLight> fitted(upload->lights.begin(), upload->lights.end());

  // The same seed again: the same lights (fit is deterministic).
  scene.adopt(model(0, 1), "upload:other.obj", Adoption{.lights = Adoption::Lights::automatic});
  scene.adopt(far, "upload:far.obj", Adoption{.lights = Adoption::Lights::automatic});
  for (uint32_t slot = 0; slot < 40; ++slot) CHECK(same(scene.lightAt(slot), fitted[slot]));

  // After an edit the lights are the user's: kept as they are.
  protocol::LightPatch patch;
  patch.intensity = 3.0;
  scene.patchLight(0, patch);
  CHECK_FALSE(scene.lightRecipe().has_value());
  const scene::PointLight edited = scene.lightAt(0);
  upload = scene.adopt(model(0, 1), "upload:third.obj", Adoption{.lights = Adoption::Lights::automatic});
  CHECK(same(scene.lightAt(0), edited));
  CHECK(same(upload->lights[0], edited));

  // ?lights=fit regenerates anyway (the current count, seed 1); keep keeps generated ones too.
  scene.adopt(far, "upload:far.obj", Adoption{.lights = Adoption::Lights::fit});
  CHECK(scene.lightCount() == 40);
  CHECK(scene.lightRecipe().has_value());
  const scene::PointLight kept = scene.lightAt(5);
  scene.adopt(model(0, 1), "upload:x.obj", Adoption{.lights = Adoption::Lights::keep});
  CHECK(same(scene.lightAt(5), kept));

  // Lights generated with the generator's defaults carry a recipe; added ones end it.
  scene.replaceLights(std::vector<scene::PointLight>{light(1)}, service::LightRecipe{1, 3});
  CHECK(scene.lightRecipe()->seed == 3);
  scene.addLights(std::vector<scene::PointLight>{light(2)});
  CHECK_FALSE(scene.lightRecipe().has_value());
}


TEST_CASE("session scene: a snapshot restores camera, settings, materials and lights; a bad one changes nothing") {
  SessionScene original(100, {});
  original.adopt(model(0, 3), "library:a.glb", Adoption{.lights = Adoption::Lights::model});
  original.addLights(std::vector<scene::PointLight>{light(1, 2.0f), light(2, 3.0f), light(3, 4.0f)});
  original.removeLight(original.slotOf("1"));
  protocol::CameraPatch fov;
  fov.fovY = 33.0;
  original.patchCamera(fov);
  protocol::SettingsPatch settings;
  settings.exposure = 1.7;
  settings.technique = "tiled";
  original.patchSettings(settings, Clock::now());
  protocol::MaterialPatch rough;
  rough.roughness = 0.125;
  original.patchMaterial(2, rough);
  const protocol::Snapshot snapshot = original.snapshot();
  REQUIRE(snapshot.lights.list.has_value());
  CHECK_FALSE(snapshot.lights.generated.has_value());
  CHECK(snapshot.lights.list->size() == 2);

  // Onto another session holding the same model: the same state, in one GPU update each.
  SessionScene copy(100, {});
  copy.adopt(model(5, 3), "library:a.glb", Adoption{.lights = Adoption::Lights::model});
  GpuMirror gpu;  // the session's GPU lights before the restore: the model's 5
  for (uint32_t slot = 0; slot < copy.lightCount(); ++slot) gpu.lights.push_back(copy.lightAt(slot));
  SessionScene::Restored restored = copy.restore(snapshot, "", Clock::now());
  CHECK(restored.materials.size() == 3);
  gpu.apply(restored.lights);
  checkConsistent(copy, gpu);
  CHECK(json(copy.snapshot()) == json(snapshot));
  CHECK(copy.camera().fovYDegrees == 33.0f);
  CHECK(copy.settings().technique == render::Technique::Tiled);
  CHECK(copy.materials()[2].roughness == 0.125f);

  // Generated lights travel as their recipe and come back the same.
  SessionScene generated(1000, {});
  generated.adopt(model(0, 1), "builtin:default", Adoption{.lights = Adoption::Lights::model});
  const std::vector<scene::PointLight> made = {light(0), light(1)};
  generated.replaceLights(made, service::LightRecipe{50, 3});
  generated.adopt(model(0, 1), "builtin:default", Adoption{.lights = Adoption::Lights::fit});
  const protocol::Snapshot recipe = generated.snapshot();
  REQUIRE(recipe.lights.generated.has_value());
  CHECK(recipe.lights.generated->count == 50);
  SessionScene again(1000, {});
  again.adopt(model(0, 1), "builtin:default", Adoption{});
  again.restore(recipe, "", Clock::now());
  REQUIRE(again.lightCount() == 50);
  for (uint32_t slot = 0; slot < 50; ++slot) CHECK(same(again.lightAt(slot), generated.lightAt(slot)));

  // Refusals name the member under the pointer given, and change nothing.
  const protocol::Snapshot good = copy.snapshot();
  protocol::Snapshot bad = good;
  bad.camera.far = bad.camera.near / 2;
  ProblemError far = problemOf([&] { copy.restore(bad, "/snapshot", Clock::now()); });
  CHECK(far.problem().pointer == "/snapshot/camera/far");
  bad = good;
  bad.materials.push_back({7, "x", {1, 1, 1}, 0, 1});
  CHECK(problemOf([&] { copy.restore(bad, "", Clock::now()); }).problem().pointer == "/materials/3/id");
  bad = good;
  bad.lights.generated = protocol::LightsRecipe{1, 1};
  CHECK(problemOf([&] { copy.restore(bad, "", Clock::now()); }).problem().pointer == "/lights");
  bad = good;
  bad.lights.list->resize(101);
  CHECK(problemOf([&] { copy.restore(bad, "", Clock::now()); }).problem().status == 413);
  CHECK(json(copy.snapshot()) == json(good));
}

TEST_CASE("session scene: clear coat, sheen, ior and specular patch, snapshot, and restore as loaded when left out") {
  // A model whose material 1 has every extension's factor (as a glTF file gives them).
  std::shared_ptr<scene::Scene> loaded = model(0, 2);
  scene::Material& file = loaded->materials[1];
  file.clearcoat = 0.5f;
  file.clearcoatRoughness = 0.25f;
  file.sheenColor = glm::vec3(0.5f, 0.25f, 0.125f);
  file.sheenRoughness = 0.75f;
  file.ior = 1.25f;
  file.specular = 0.5f;
  SessionScene scene(5, {});
  scene.adopt(loaded, "library:a.glb", Adoption{});
  const protocol::Snapshot fresh = scene.snapshot();
  const protocol::Material& wire = fresh.materials.at(1);
  CHECK(wire.clearcoat == 0.5);
  CHECK(wire.clearcoatRoughness == 0.25);
  CHECK(wire.sheenColor == protocol::Color{0.5, 0.25, 0.125});
  CHECK(wire.sheenRoughness == 0.75);
  CHECK(wire.ior == 1.25);
  CHECK(wire.specular == 0.5);
  CHECK(fresh.materials.at(0).clearcoat == 0.0);
  CHECK(fresh.materials.at(0).ior == 1.5);

  // A patch sets exactly what it names, in the write the renderer gets.
  protocol::MaterialPatch patch;
  patch.clearcoat = 1.0;
  patch.sheenColor = protocol::Color{0.0, 0.0, 0.0};
  patch.ior = 3.0;
  render::MaterialWrite write = scene.patchMaterial(1, patch);
  CHECK(write.material.clearcoat == 1.0f);
  CHECK(write.material.clearcoatRoughness == 0.25f);
  CHECK(write.material.sheenColor == glm::vec3(0.0f));
  CHECK(write.material.sheenRoughness == 0.75f);
  CHECK(write.material.ior == 3.0f);
  CHECK(write.material.specular == 0.5f);
  CHECK(write.material.layered());
  const protocol::Snapshot patched = scene.snapshot();
  CHECK(patched.materials.at(1).clearcoat == 1.0);
  CHECK(patched.materials.at(1).ior == 3.0);

  // Restored onto a session of the same model: the patched values.
  SessionScene other(5, {});
  other.adopt(loaded, "library:a.glb", Adoption{});
  SessionScene::Restored restored = other.restore(patched, "", Clock::now());
  REQUIRE(restored.materials.size() == 2);
  CHECK(restored.materials[1].material.clearcoat == 1.0f);
  CHECK(other.materials()[1].ior == 3.0f);
  CHECK(json(other.snapshot()) == json(patched));

  // A snapshot from before these members (left out): the model file's values, even onto a
  // session that has patched them.
  protocol::Snapshot old = patched;
  for (protocol::Material& m : old.materials) {
    m.clearcoat.reset(), m.clearcoatRoughness.reset(), m.sheenColor.reset();
    m.sheenRoughness.reset(), m.ior.reset(), m.specular.reset();
  }
  other.restore(old, "", Clock::now());
  const scene::Material& back = other.materials()[1];
  CHECK(back.clearcoat == 0.5f);
  CHECK(back.clearcoatRoughness == 0.25f);
  CHECK(back.sheenColor == glm::vec3(0.5f, 0.25f, 0.125f));
  CHECK(back.sheenRoughness == 0.75f);
  CHECK(back.ior == 1.25f);
  CHECK(back.specular == 0.5f);
  CHECK(json(other.snapshot().materials) == json(fresh.materials));
}

TEST_CASE("session scene: a model's directional lights join the sun unless its lights are kept; its cameras are selectable") {
  SessionScene scene(8, render::SceneSettings{});
  auto lit = model(1, 1);
  lit->extraSuns = {scene::Sun{glm::vec3(0.0f, -1.0f, 0.0f), glm::vec3(1.0f), 3.0f}};
  lit->droppedSuns = 1;
  scene::ModelCamera perspective;
  perspective.name = "front";
  perspective.yfov = 0.5f;
  perspective.znear = 0.1f;
  perspective.zfar = 30.0f;
  perspective.position = glm::vec3(0.0f, 1.0f, 5.0f);
  scene::ModelCamera flat = perspective;
  flat.perspective = false;
  lit->cameras = {perspective, flat};
  scene.adopt(lit, "upload:lit.gltf", Adoption{.lights = Adoption::Lights::model});
  REQUIRE(scene.settings().extraSuns.size() == 1);
  CHECK(scene.settings().extraSuns[0].intensity == 3.0f);
  CHECK(scene.model().directionalLights == 2);
  CHECK(scene.model().directionalDropped == 1);
  CHECK(scene.model().pointLights == 1);
  CHECK(scene.model().cameras.size() == 2);

  // ?lights=keep keeps the session's suns as well as its lights; other choices take the model's.
  scene.adopt(model(0, 1), "upload:plain.obj", Adoption{.lights = Adoption::Lights::keep});
  CHECK(scene.settings().extraSuns.size() == 1);
  scene.adopt(model(0, 1), "upload:plain.obj", Adoption{.lights = Adoption::Lights::fit});
  CHECK(scene.settings().extraSuns.empty());

  // Suns through a settings patch: normalized; a zero direction names its member.
  protocol::SettingsPatch patch;
  patch.suns = std::vector<protocol::Sun>{{{0, -2, 0}, {1, 1, 1}, 2}};
  scene.patchSettings(patch, Clock::now());
  REQUIRE(scene.settings().extraSuns.size() == 1);
  CHECK(scene.settings().extraSuns[0].direction == glm::vec3(0.0f, -1.0f, 0.0f));
  patch.suns = std::vector<protocol::Sun>{{{0, 0, 0}, {1, 1, 1}, 2}};
  CHECK(problemOf([&] { scene.patchSettings(patch, Clock::now()); }).problem().pointer == "/suns/0/direction");
  CHECK(scene.settings().extraSuns.size() == 1);

  // Cameras: a perspective one becomes the camera; an orthographic or missing one is 400.
  scene.adopt(lit, "upload:lit.gltf", Adoption{.lights = Adoption::Lights::model});
  const scene::Camera& camera = scene.selectModelCamera(0);
  CHECK(camera.eye == glm::vec3(0.0f, 1.0f, 5.0f));
  CHECK(camera.target.z < 5.0f);
  CHECK(camera.fovYDegrees == doctest::Approx(0.5f * 180.0f / 3.14159265f));
  CHECK(camera.nearPlane == 0.1f);
  CHECK(camera.farPlane == 30.0f);
  CHECK(problemOf([&] { scene.selectModelCamera(1); }).problem().pointer == "/modelCamera");
  CHECK(problemOf([&] { scene.selectModelCamera(2); }).problem().pointer == "/modelCamera");
}

}  // namespace myriad

namespace myriad {
namespace {

// A quad "body" at (-1, 1, 0) with a child "arm" two units to its right, as a loader makes it
// (instances placed by their nodes' rest world transforms). `armScale`: the arm node's scale.
std::shared_ptr<scene::Scene> parentChild(float armScale = 1.0f) {
  auto s = model(0, 1);
  scene::Mesh quad;
  for (glm::vec2 p : {glm::vec2(-0.5f, -0.5f), glm::vec2(0.5f, -0.5f), glm::vec2(0.5f, 0.5f),
                      glm::vec2(-0.5f, 0.5f)}) {
    scene::Vertex v;
    v.position = glm::vec3(p, 0.0f);
    quad.vertices.push_back(v);
  }
  quad.indices = {0, 1, 2, 0, 2, 3};
  s->meshes.push_back(quad);
  scene::Node body;
  body.name = "body";
  body.translation = glm::vec3(-1.0f, 1.0f, 0.0f);
  scene::Node arm;
  arm.name = "arm";
  arm.parent = 0;
  arm.translation = glm::vec3(2.0f, 0.0f, 0.0f);
  arm.scale = glm::vec3(armScale);
  s->nodes = {body, arm};
  scene::Instance b{0, 0, scene::localMatrix(body)};
  b.node = 0;
  scene::Instance a{0, 0, scene::localMatrix(body) * scene::localMatrix(arm)};
  a.node = 1;
  s->instances = {b, a};
  return s;
}

}  // namespace
}  // namespace myriad

TEST_CASE("session scene: a model's node tree becomes one object per node; one that cannot stays whole") {
  using namespace myriad;
  SessionScene scene(8, render::SceneSettings{});
  std::shared_ptr<const scene::Scene> flat =
      scene.adopt(parentChild(), "upload:tree.gltf", Adoption{.assetId = "a-0000000000000001"});
  const auto& objects = scene.graph().objects();
  REQUIRE(objects.size() == 2);
  const service::SceneObject& root = objects.at(1);
  const service::SceneObject& arm = objects.at(2);
  CHECK(root.name == "upload:tree.gltf");
  CHECK(root.parent == 0);
  CHECK(root.node == 0);
  CHECK_FALSE(root.subtree);
  CHECK(arm.name == "arm");
  CHECK(arm.parent == 1);
  CHECK(arm.transform.translation == glm::vec3(2.0f, 0.0f, 0.0f));
  // Unedited, each instance is where the file put it.
  REQUIRE(flat->instances.size() == 2);
  CHECK(flat->instances[0].object == 1);
  CHECK(flat->instances[1].object == 2);
  CHECK(glm::vec3(flat->instances[1].transform[3]) == glm::vec3(1.0f, 1.0f, 0.0f));
  // Moving the root moves the arm's instance, written in place.
  service::SceneObject moved = root;
  moved.transform.translation = glm::vec3(0.0f, 1.0f, 0.0f);
  const service::SceneChange change = scene.replaceObject(moved);
  REQUIRE(change.moved.has_value());
  REQUIRE(change.moved->writes.size() == 2);
  CHECK(glm::vec3(change.moved->writes[1].transform[3]) == glm::vec3(2.0f, 1.0f, 0.0f));

  // An arm scaled to zero cannot be an object (no inverse): the model is one object.
  scene.adopt(parentChild(0.0f), "upload:flat.gltf", Adoption{.assetId = "a-0000000000000002"});
  REQUIRE(scene.graph().objects().size() == 1);
  CHECK(scene.graph().objects().begin()->second.node == -1);
  CHECK(scene.graph().objects().begin()->first == 3);
}

TEST_CASE("session scene: semantic class names take the lowest free ids and keep them") {
  using namespace myriad;
  SessionScene scene(8, render::SceneSettings{});
  scene.adopt(model(0, 1), "builtin:default", Adoption{});
  const std::string asset = scene.graph().assets().front().id;
  auto object = [&](std::string name, uint32_t integer) {
    service::SceneObject o;
    o.asset = asset;
    o.semanticClass = std::move(name);
    o.semantic = integer;
    return o;
  };
  std::vector<uint32_t> ids;
  scene.addObjects({object("car", 0), object("", 1), object("person", 0), object("car", 0)}, &ids);
  const auto& objects = scene.graph().objects();
  CHECK(objects.at(ids[0]).semantic == 2);  // 1 is an integer of the same request
  CHECK(objects.at(ids[2]).semantic == 3);
  CHECK(objects.at(ids[3]).semantic == 2);
  CHECK(scene.semanticClasses().size() == 2);
  // A name keeps its id when no object uses it; a refused edit allocates nothing.
  service::SceneObject next = objects.at(ids[2]);
  next.semanticClass.clear();
  next.semantic = 0;
  scene.replaceObject(next);
  next.semanticClass = "tree";
  next.parent = 999;  // no such object: refused
  CHECK_THROWS_AS(scene.replaceObject(next), ProblemError);
  CHECK(scene.semanticClasses().size() == 2);
  next.parent = 0;
  scene.replaceObject(next);
  CHECK(scene.graph().object(ids[2]).semantic == 4);
  // A snapshot brings its names back, and names its objects use that it lacks get new ids.
  const protocol::Snapshot snapshot = scene.snapshot();
  REQUIRE(snapshot.scene->classes.has_value());
  CHECK(snapshot.scene->classes->size() == 3);
  CHECK(snapshot.scene->objects[1].semantic.name == std::optional<std::string>("car"));
  next.semanticClass = "bus";
  scene.replaceObject(next);
  scene.restore(snapshot, "", Clock::now());
  CHECK(scene.graph().object(ids[2]).semantic == 4);
  CHECK(scene.graph().classes().size() == 3);
}

namespace myriad {

TEST_CASE("session scene: shadows.local is maps by default, patched by name, checked") {
  service::SessionScene scene(5, {});
  const service::Clock::time_point t0 = service::Clock::now();
  CHECK(scene.settings().shadows.local == render::LocalShadows::Maps);
  protocol::SettingsPatch bad;
  bad.shadows = protocol::ShadowsPatch{};
  bad.shadows->local = "raytraced";
  try {
    scene.patchSettings(bad, t0);
    FAIL("no problem for an unknown shadows.local");
  } catch (const service::ProblemError& e) {
    CHECK(e.problem().status == 400);
    CHECK(e.problem().pointer == "/shadows/local");
  }
  CHECK(scene.settings().shadows.local == render::LocalShadows::Maps);
  protocol::SettingsPatch patch;
  patch.shadows = protocol::ShadowsPatch{};
  patch.shadows->local = "stochastic";
  scene.patchSettings(patch, t0);
  CHECK(scene.settings().shadows.local == render::LocalShadows::Stochastic);
  CHECK(scene.settings().shadows.maxShadowedLights == render::kDefaultShadowedLights);  // kept
  CHECK(scene.frameSettings(render::FrameSettings{}, std::nullopt, t0).shadows.local ==
        render::LocalShadows::Stochastic);
}

TEST_CASE("session scene: the built-in scene's own lights come back from its snapshot as they were") {
  // A new session of the built-in model (api_sessions.cpp populate): the scene's lights, named by
  // the recipe they were made from.
  service::SessionScene original(100000, {});
  original.adopt(std::make_shared<scene::Scene>(scene::makeBuiltinScene(64, 7)), "builtin:default",
                 service::Adoption{.lights = service::Adoption::Lights::model,
                          .recipe = service::LightRecipe{64, 7},
                          .lightingFromModel = true});
  const protocol::Snapshot snapshot = original.snapshot();
  REQUIRE(snapshot.lights.generated.has_value());
  CHECK(snapshot.lights.generated->count == 64);
  service::SessionScene copy(100000, {});
  copy.adopt(std::make_shared<scene::Scene>(scene::makeBuiltinScene(256, 1)), "builtin:default",
             service::Adoption{});
  copy.restore(snapshot, "", service::Clock::now());
  REQUIRE(copy.lightCount() == 64);
  size_t differ = 0;
  for (uint32_t slot = 0; slot < 64; ++slot) differ += same(copy.lightAt(slot), original.lightAt(slot)) ? 0 : 1;
  CHECK(differ == 0);  // before: generated again around the model's bounds instead
}

}  // namespace myriad
