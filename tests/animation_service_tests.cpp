// The scene clock and the frame's pose in SessionScene, without HTTP or Vulkan: play, pause,
// seek and rate at chosen instants, and poseAt mapping each object's posed asset instances to
// the flat scene with the object's world transform (service/session_scene.h).
#include <doctest/doctest.h>

#include <chrono>
#include <memory>

#include <glm/gtc/matrix_transform.hpp>

#include "service/session_scene.h"

namespace myriad {
namespace {

using service::Adoption;
using service::Clock;
using service::SceneObject;
using service::SessionScene;

// A model of two nodes, each holding a triangle: "mover" slides +x by 4 over 2 s, "still" never
// moves.
std::shared_ptr<scene::Scene> animatedModel() {
  auto s = std::make_shared<scene::Scene>();
  s->nodes.push_back({"mover", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  s->nodes.push_back({"still", -1, {0, 3, 0}, {1, 0, 0, 0}, {1, 1, 1}});
  scene::Mesh mesh;
  mesh.name = "tri";
  mesh.vertices.resize(3);
  mesh.vertices[1].position = {1, 0, 0};
  mesh.vertices[2].position = {0, 1, 0};
  mesh.indices = {0, 1, 2};
  s->meshes.push_back(mesh);
  s->materials.emplace_back();
  for (int32_t node : {0, 1}) {
    scene::Instance instance;
    instance.node = node;
    instance.transform = glm::translate(glm::mat4(1.0f), s->nodes[size_t(node)].translation);
    s->instances.push_back(instance);
  }
  scene::Animation clip;
  clip.name = "slide";
  clip.duration = 2.0f;
  clip.channels.push_back({0,
                           scene::AnimationPath::translation,
                           scene::Interpolation::linear,
                           {0, 2},
                           {0, 0, 0, 4, 0, 0}});
  s->animations.push_back(clip);
  return s;
}

glm::vec3 translationOf(const glm::mat4& m) {
  return glm::vec3(m[3]);
}

}  // namespace

TEST_CASE("scene clock: play, pause, seek and rate continue from the time reached") {
  SessionScene scene(8, render::SceneSettings{});
  scene.adopt(animatedModel(), "upload:slide.gltf", Adoption{});
  const Clock::time_point t0 = Clock::now();
  scene.patchClock(std::nullopt, 0.0, std::nullopt, t0);  // seek to 0 at t0
  CHECK(scene.clock(t0 + std::chrono::milliseconds(500)).time == doctest::Approx(0.5));
  CHECK(scene.clock(t0).duration == 2.0f);
  // Pause at t0 + 1 s: the time stays at 1.
  scene.patchClock(false, std::nullopt, std::nullopt, t0 + std::chrono::seconds(1));
  CHECK(scene.clock(t0 + std::chrono::seconds(5)).time == doctest::Approx(1.0));
  CHECK_FALSE(scene.moving());
  // Play at rate 2 from t0 + 5 s: one second later the clock reads 3.
  scene.patchClock(true, std::nullopt, 2.0, t0 + std::chrono::seconds(5));
  CHECK(scene.moving());
  CHECK(scene.clock(t0 + std::chrono::seconds(6)).time == doctest::Approx(3.0));
  // Backwards at rate -1: never below 0.
  scene.patchClock(std::nullopt, std::nullopt, -1.0, t0 + std::chrono::seconds(6));
  CHECK(scene.clock(t0 + std::chrono::seconds(7)).time == doctest::Approx(2.0));
  CHECK(scene.clock(t0 + std::chrono::seconds(60)).time == 0.0);
}

TEST_CASE(
    "scene pose: every object's animated instances, placed by the object, at the frame's time") {
  SessionScene scene(8, render::SceneSettings{});
  scene.adopt(animatedModel(), "upload:slide.gltf", Adoption{});
  const std::string asset = scene.graph().assets().at(0).id;
  // A second object of the asset, 10 up, holding its clip instead of looping.
  SceneObject second;
  second.asset = asset;
  second.transform.translation = {0, 10, 0};
  second.loop = false;
  std::vector<uint32_t> ids;
  scene.addObjects({second}, &ids);
  REQUIRE(ids.size() == 1);

  const std::shared_ptr<const render::ScenePose> pose = scene.poseAt(3.0);
  REQUIRE(pose);
  CHECK(pose->time == 3.0);
  CHECK(pose->poses.empty());  // nothing skinned or morphed
  // Object 1 (root, looping): 3 s is 1 s into the clip, x = 2. Object 2 (held): x = 4, y + 10.
  // Only the "mover" node's instance of each: flat instances 0 and 2.
  REQUIRE(pose->transforms.size() == 2);
  CHECK(pose->transforms[0].index == 0);
  CHECK(translationOf(pose->transforms[0].transform) == glm::vec3(2, 0, 0));
  CHECK(pose->transforms[1].index == 2);
  CHECK(translationOf(pose->transforms[1].transform) == glm::vec3(4, 10, 0));
  // The same time, the same pose; frames take it from ?time= or the clock.
  CHECK(scene.poseAt(3.0)->transforms[1].transform == pose->transforms[1].transform);
  render::FrameSettings request;
  const render::FrameSettings frame = scene.frameSettings(request, 3.0, Clock::now());
  REQUIRE(frame.pose);
  CHECK(frame.pose->transforms[0].transform == pose->transforms[0].transform);

  // The rest pose for an object without a clip: no transform of it.
  SceneObject rest = scene.graph().object(ids[0]);
  rest.clip = -1;
  scene.replaceObject(rest);
  REQUIRE(scene.poseAt(3.0)->transforms.size() == 1);
  // A scene without animation has no pose.
  SessionScene plain(8, render::SceneSettings{});
  auto still = animatedModel();
  still->animations.clear();
  plain.adopt(still, "upload:still.gltf", Adoption{});
  CHECK_FALSE(plain.poseAt(1.0));
}

}  // namespace myriad

namespace myriad {

// The CPU side of a posed frame (docs/performance.md): poseAt for 100 objects of a 64-joint
// skinned asset, and for 10,000 objects of a node-animated one. Timed, reported, bounded loosely.
TEST_CASE("scene pose: what posing costs on the CPU per frame") {
  using ms = std::chrono::duration<double, std::milli>;
  auto skinned = std::make_shared<scene::Scene>();
  for (int j = 0; j < 64; ++j) {
    skinned->nodes.push_back(
        {"joint" + std::to_string(j), j - 1, {0, 0.1f, 0}, {1, 0, 0, 0}, {1, 1, 1}});
  }
  skinned->nodes.push_back({"mesh", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  scene::Skin skin;
  for (uint32_t j = 0; j < 64; ++j) {
    skin.joints.push_back(j);
    skin.inverseBind.push_back(
        glm::translate(glm::mat4(1.0f), glm::vec3(0, -0.1f * float(j + 1), 0)));
  }
  skinned->skins.push_back(skin);
  scene::Mesh mesh;
  mesh.vertices.resize(3);
  mesh.indices = {0, 1, 2};
  mesh.joints.assign(3, glm::uvec4(0));
  mesh.weights.assign(3, glm::vec4(1, 0, 0, 0));
  skinned->meshes.push_back(mesh);
  skinned->materials.emplace_back();
  scene::Instance instance;
  instance.node = 64;
  instance.skin = 0;
  skinned->instances.push_back(instance);
  scene::Animation wave;
  wave.duration = 1.0f;
  for (uint32_t j = 0; j < 64; ++j) {
    const glm::quat q = glm::angleAxis(0.3f, glm::vec3(0, 0, 1));
    wave.channels.push_back({j,
                             scene::AnimationPath::rotation,
                             scene::Interpolation::linear,
                             {0, 1},
                             {0, 0, 0, 1, q.x, q.y, q.z, q.w}});
  }
  skinned->animations.push_back(wave);

  SessionScene scene(8, render::SceneSettings{}, 20000);
  scene.adopt(skinned, "upload:skinned.gltf", Adoption{});
  const std::string asset = scene.graph().assets().at(0).id;
  std::vector<SceneObject> more(99);
  for (size_t i = 0; i < more.size(); ++i) {
    more[i].asset = asset;
    more[i].transform.translation = {float(i), 0, 0};
  }
  std::vector<uint32_t> ids;
  scene.addObjects(more, &ids);
  auto start = std::chrono::steady_clock::now();
  constexpr int kFrames = 50;
  for (int f = 0; f < kFrames; ++f) {
    const auto pose = scene.poseAt(0.01 * f);
    REQUIRE(pose->poses.size() == 100);
    REQUIRE(pose->poses[0].joints.size() == 64);
  }
  const double skinnedMs = ms(std::chrono::steady_clock::now() - start).count() / kFrames;

  SessionScene nodes(8, render::SceneSettings{}, 20000);
  nodes.adopt(animatedModel(), "upload:slide.gltf", Adoption{});
  const std::string slide = nodes.graph().assets().at(0).id;
  std::vector<SceneObject> many(9999);
  for (size_t i = 0; i < many.size(); ++i) {
    many[i].asset = slide;
    many[i].transform.translation = {float(i % 100), float(i / 100), 0};
  }
  nodes.addObjects(many, &ids);
  start = std::chrono::steady_clock::now();
  for (int f = 0; f < 10; ++f) REQUIRE(nodes.poseAt(0.1 * f)->transforms.size() == 10000);
  const double nodesMs = ms(std::chrono::steady_clock::now() - start).count() / 10;
  MESSAGE("poseAt: 100 objects x 64 joints " << skinnedMs << " ms; 10,000 node-animated objects "
                                             << nodesMs << " ms");
  CHECK(skinnedMs < 50.0);
  CHECK(nodesMs < 500.0);
}

}  // namespace myriad
