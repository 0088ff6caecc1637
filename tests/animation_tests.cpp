// Animation on the CPU (scene/animation.h) with hand-computed values, the loader's nodes, skins,
// morph targets and animations from real files, and the wire format's checks of them.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "gltf_builder.h"
#include "loader/loader.h"
#include "loader/scene_wire.h"
#include "loader_support.h"
#include "scene/animation.h"
#include "scene/model_loader.h"

using namespace myriad;

namespace {

const std::filesystem::path kModels = test::assimpModels();

scene::AnimationChannel channel(scene::AnimationPath path, scene::Interpolation interpolation,
                                std::vector<float> times, std::vector<float> values) {
  return {0, path, interpolation, std::move(times), std::move(values)};
}

glm::vec3 sample3(const scene::AnimationChannel& c, double t) {
  float out[3];
  scene::sampleChannel(c, t, std::span<float>(out, 3));
  return {out[0], out[1], out[2]};
}

glm::quat sampleQ(const scene::AnimationChannel& c, double t) {
  float out[4];
  scene::sampleChannel(c, t, std::span<float>(out, 4));
  return glm::quat(out[3], out[0], out[1], out[2]);
}

bool near(const glm::vec3& a, const glm::vec3& b, float eps = 1e-5f) {
  return glm::all(glm::lessThanEqual(glm::abs(a - b), glm::vec3(eps)));
}

std::string wireRejection(const scene::Scene& s) {
  try {
    loader::decodeScene(loader::encodeScene(s));
    return "";
  } catch (const loader::SceneWireError& e) {
    return e.what();
  }
}

std::string loadRejection(const std::string& bytes, const std::string& name) {
  try {
    loader::loadModelBytes(bytes, name);
    return "";
  } catch (const loader::ModelRejected& e) {
    return e.what();
  }
}

// A triangle on node 0 animated by one translation channel (times and values as given).
std::string animatedTriangle(const std::vector<float>& times, const std::vector<float>& values,
                             const char* interpolation = "LINEAR") {
  test::GltfBuilder b;
  const int pos = b.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
  const int in = b.floats(times, "SCALAR", 1);
  const int out = b.floats(values, "VEC3", 3);
  b.nodes.push_back("{\"mesh\":0}");
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                     "}}]}");
  b.animations.push_back("{\"name\":\"move\",\"samplers\":[{\"input\":" + std::to_string(in) +
                         ",\"output\":" + std::to_string(out) + ",\"interpolation\":\"" +
                         interpolation +
                         "\"}],\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,"
                         "\"path\":\"translation\"}}]}");
  return b.json();
}

}  // namespace

TEST_CASE("animation: step, linear and cubic spline sampling") {
  using P = scene::AnimationPath;
  using I = scene::Interpolation;
  const auto step = channel(P::translation, I::step, {0, 1, 2}, {0, 0, 0, 1, 0, 0, 4, 0, 0});
  CHECK(sample3(step, 0.999).x == 0.0f);
  CHECK(sample3(step, 1.0).x == 1.0f);
  CHECK(sample3(step, 1.5).x == 1.0f);
  CHECK(sample3(step, 9.0).x == 4.0f);

  const auto linear = channel(P::translation, I::linear, {0, 1, 2}, {0, 0, 0, 1, 0, 0, 4, 2, 0});
  CHECK(near(sample3(linear, 1.5), {2.5f, 1.0f, 0.0f}));
  CHECK(near(sample3(linear, -1.0), {0, 0, 0}));  // before the first key: the first value
  CHECK(near(sample3(linear, 5.0), {4, 2, 0}));   // after the last: the last

  // Hermite over [0, 2] with out-tangent 2 at key 0 and in-tangent 0 at key 1, at u = 0.5:
  // 0.5*0 + 0.125*2*2 + 0.5*1 - 0.125*2*0 = 1.
  const auto cubic = channel(P::translation, I::cubicSpline, {0, 2},
                             {0, 0, 0, 0, 0, 0, 2, 0, 0,   /* key 0: in, value, out */
                              0, 0, 0, 1, 0, 0, 9, 0, 0}); /* key 1 */
  CHECK(sample3(cubic, 1.0).x == doctest::Approx(1.0f));
  CHECK(sample3(cubic, 0.0).x == 0.0f);
  CHECK(sample3(cubic, 2.0).x == 1.0f);
  // u = 0.25: h00 = 0.84375, h10 = 0.140625, h01 = 0.15625, h11 = -0.046875 -> 0.5625 + 0.15625.
  CHECK(sample3(cubic, 0.5).x == doctest::Approx(0.140625f * 2 * 2 + 0.15625f));
}

TEST_CASE("animation: rotations slerp along the shorter arc") {
  using P = scene::AnimationPath;
  const float s45 = std::sin(glm::radians(45.0f)), c45 = std::cos(glm::radians(45.0f));
  // From identity to 90 degrees about Y; the second key written as -q (the same rotation).
  for (float sign : {1.0f, -1.0f}) {
    const auto rot = channel(P::rotation, scene::Interpolation::linear, {0, 1},
                             {0, 0, 0, 1, 0, sign * s45, 0, sign * c45});
    const glm::quat q = sampleQ(rot, 0.5);
    CAPTURE(sign);
    // 45 degrees about +Y whichever sign: +X goes to (cos 45, 0, -sin 45).
    CHECK(near(glm::mat3_cast(q) * glm::vec3(1, 0, 0), {c45, 0.0f, -s45}));
    CHECK(glm::length(q) == doctest::Approx(1.0f));
  }
  const glm::quat third = scene::slerpShortest(
      glm::quat(1, 0, 0, 0), glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 0, 1)), 1.0f / 3.0f);
  CHECK(glm::degrees(glm::angle(third)) == doctest::Approx(30.0f).epsilon(1e-4));
}

TEST_CASE("animation: clip time loops or holds") {
  scene::Animation clip;
  clip.duration = 2.0f;
  CHECK(scene::clipTime(clip, 5.5, true) == doctest::Approx(1.5));
  CHECK(scene::clipTime(clip, 5.5, false) == 2.0);
  CHECK(scene::clipTime(clip, -0.5, true) == doctest::Approx(1.5));
  CHECK(scene::clipTime(clip, -0.5, false) == 0.0);
}

namespace {

// Two joints: joint 0 at the origin, joint 1 one unit up (its child); a triangle whose vertex 0
// follows joint 1 alone, vertex 1 both half and half, vertex 2 joint 0. One morph target moves
// every vertex +x. Joint 1 turns 90 degrees about +Z over one second.
scene::Scene twoJointScene() {
  scene::Scene s;
  s.nodes.push_back({"joint0", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  s.nodes.push_back({"joint1", 0, {0, 1, 0}, {1, 0, 0, 0}, {1, 1, 1}});
  s.nodes.push_back({"mesh", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  s.skins.push_back(
      {"skin", {0, 1}, {glm::mat4(1.0f), glm::translate(glm::mat4(1.0f), {0, -1, 0})}});
  scene::Mesh mesh;
  mesh.name = "tri";
  for (glm::vec3 p : {glm::vec3(0, 2, 0), glm::vec3(0, 2, 0), glm::vec3(1, 0, 0)}) {
    scene::Vertex v;
    v.position = p;
    mesh.vertices.push_back(v);
  }
  mesh.indices = {0, 1, 2};
  mesh.joints = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 0}};
  mesh.weights = {{1, 0, 0, 0}, {0.5f, 0.5f, 0, 0}, {1, 0, 0, 0}};
  scene::MorphTarget target;
  target.positions.assign(3, glm::vec3(1, 0, 0));
  mesh.morphTargets.push_back(target);
  mesh.morphWeights = {0.0f};
  s.meshes.push_back(mesh);
  s.materials.emplace_back();
  scene::Instance instance;
  instance.node = 2;
  instance.skin = 0;
  s.instances.push_back(instance);
  scene::Animation clip;
  clip.name = "bend";
  clip.duration = 1.0f;
  const glm::quat q = glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 0, 1));
  clip.channels.push_back({1,
                           scene::AnimationPath::rotation,
                           scene::Interpolation::linear,
                           {0, 1},
                           {0, 0, 0, 1, q.x, q.y, q.z, q.w}});
  clip.channels.push_back(
      {2, scene::AnimationPath::weights, scene::Interpolation::linear, {0, 1}, {0, 1}});
  s.animations.push_back(clip);
  return s;
}

}  // namespace

TEST_CASE("animation: a two-joint skin and a morph target posed by hand") {
  const scene::Scene s = twoJointScene();
  REQUIRE_FALSE(scene::checkAnimationData(s).has_value());
  // At rest the joint matrices are identity (world(joint) = inverse of its inverse bind).
  const auto rest = scene::poseInstances(s, -1, 0.0, false);
  REQUIRE(rest.size() == 1);
  REQUIRE(rest[0].joints.size() == 2);
  CHECK(rest[0].joints[1] == glm::mat4(1.0f));
  CHECK(rest[0].morphWeights == std::vector<float>{0.0f});

  // t = 1: joint 1 = T(0,1,0) Rz(90) T(0,-1,0); weight 1 for the morph.
  const auto posed = scene::poseInstances(s, 0, 1.0, false);
  REQUIRE(posed.size() == 1);
  CHECK_FALSE(posed[0].transform.has_value());  // skinned: placed by its joints
  REQUIRE(posed[0].morphWeights.size() == 1);
  CHECK(posed[0].morphWeights[0] == 1.0f);
  const std::vector<scene::Vertex> v =
      scene::poseVertices(s.meshes[0], posed[0].joints, posed[0].morphWeights);
  // Vertex 0: morphed to (1,2,0); joint 1: -> (1,1,0) -> Rz90 (-1,1,0) -> (-1,2,0).
  CHECK(near(v[0].position, {-1, 2, 0}));
  // Vertex 1: half of joint 0's (1,2,0) and half of joint 1's (-1,2,0).
  CHECK(near(v[1].position, {0, 2, 0}));
  // Vertex 2: joint 0 (identity), morphed: (2,0,0).
  CHECK(near(v[2].position, {2, 0, 0}));
  // Normals turn with the joints: vertex 0's +Y normal turns to -X.
  CHECK(near(v[0].normal, {-1, 0, 0}));

  // Half way (t = 0.5): 45 degrees, weight 0.5.
  const auto half = scene::poseInstances(s, 0, 0.5, false);
  const std::vector<scene::Vertex> h =
      scene::poseVertices(s.meshes[0], half[0].joints, half[0].morphWeights);
  const float r = std::sqrt(0.5f);
  // (0.5,2,0) -> (0.5,1,0) -> Rz45 (0.5r - r, 0.5r + r) -> +1 y.
  CHECK(near(h[0].position, {0.5f * r - r, 0.5f * r + r + 1.0f, 0}));
  // The posed bounds hold the posed vertices (the mesh's bind-space box does not).
  const scene::Bounds bounds = scene::posedBounds(s, 0, 1.0, false);
  CHECK(near(bounds.min, {-1, 0, 0}));
  CHECK(near(bounds.max, {2, 2, 0}));
  // Looping: t = 1.5 of a 1 s clip is t = 0.5.
  const auto looped = scene::poseInstances(s, 0, 1.5, true);
  CHECK(looped[0].joints[1] == half[0].joints[1]);
}

TEST_CASE("animation: node animation moves an unskinned instance and its children") {
  scene::Scene s;
  s.nodes.push_back({"parent", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  s.nodes.push_back({"child", 0, {1, 0, 0}, {1, 0, 0, 0}, {2, 2, 2}});
  s.nodes.push_back({"still", -1, {0, 5, 0}, {1, 0, 0, 0}, {1, 1, 1}});
  scene::Mesh mesh;
  mesh.vertices.resize(3);
  mesh.indices = {0, 1, 2};
  s.meshes.push_back(mesh);
  for (int32_t node : {1, 2}) {
    scene::Instance instance;
    instance.node = node;
    s.instances.push_back(instance);
  }
  scene::Animation clip;
  clip.duration = 2.0f;
  clip.channels.push_back({0,
                           scene::AnimationPath::translation,
                           scene::Interpolation::linear,
                           {0, 2},
                           {0, 0, 0, 0, 0, 4}});
  s.animations.push_back(clip);
  const auto posed = scene::poseInstances(s, 0, 1.0, false);
  REQUIRE(posed.size() == 1);  // the still node's instance is not posed
  CHECK(posed[0].instance == 0);
  REQUIRE(posed[0].transform.has_value());
  CHECK(near(glm::vec3((*posed[0].transform)[3]), {1, 0, 2}));
  CHECK((*posed[0].transform)[0][0] == 2.0f);  // the child's own scale is kept
}

TEST_CASE("animation: AnimatedMorphCube and simple_skin load with their animation data") {
  const scene::Scene cube = scene::loadModel(
      kModels / "glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
  REQUIRE(cube.meshes.size() == 1);
  const scene::Mesh& mesh = cube.meshes[0];
  REQUIRE(mesh.morphTargets.size() == 2);
  CHECK(mesh.morphWeights == std::vector<float>{0.0f, 0.0f});
  REQUIRE(mesh.morphTargets[0].positions.size() == mesh.vertices.size());
  float largest = 0.0f;
  for (const glm::vec3& d : mesh.morphTargets[0].positions)
    largest = std::max(largest, glm::length(d));
  CHECK(largest > 0.005f);
  REQUIRE(cube.animations.size() == 1);
  CHECK(cube.animations[0].name == "Square");
  CHECK(cube.animations[0].duration == doctest::Approx(4.2f).epsilon(1e-4));
  REQUIRE(cube.animations[0].channels.size() == 1);
  const scene::AnimationChannel& weights = cube.animations[0].channels[0];
  CHECK(weights.path == scene::AnimationPath::weights);
  CHECK(weights.times.size() == 127);
  CHECK(weights.values.size() == 127 * 2);
  REQUIRE(cube.instances.size() == 1);
  CHECK(cube.instances[0].node == int32_t(weights.node));
  CHECK(cube.instances[0].skin == -1);

  const scene::Scene skin = scene::loadModel(kModels / "glTF2/simple_skin/simple_skin.gltf");
  REQUIRE(skin.nodes.size() == 3);
  CHECK(skin.nodes[0].parent == -1);
  CHECK(skin.nodes[1].parent == 0);
  CHECK(skin.nodes[2].parent == 1);
  CHECK(skin.nodes[1].translation == glm::vec3(0, 1, 0));
  REQUIRE(skin.skins.size() == 1);
  CHECK(skin.skins[0].joints == std::vector<uint32_t>{1, 2});
  CHECK(glm::vec3(skin.skins[0].inverseBind[0][3]) == glm::vec3(-0.5f, -1.0f, 0.0f));
  REQUIRE(skin.instances.size() == 1);
  CHECK(skin.instances[0].skin == 0);
  CHECK(skin.instances[0].transform == glm::mat4(1.0f));
  REQUIRE(skin.meshes[0].skinned());
  for (size_t v = 0; v < skin.meshes[0].vertices.size(); ++v) {
    const glm::vec4 w = skin.meshes[0].weights[v];
    CHECK(w.x + w.y + w.z + w.w == doctest::Approx(1.0f));
  }
  REQUIRE(skin.animations.size() == 1);
  CHECK(skin.animations[0].duration == doctest::Approx(5.5f));
  const auto rotation =
      std::find_if(skin.animations[0].channels.begin(), skin.animations[0].channels.end(),
                   [](const auto& c) { return c.path == scene::AnimationPath::rotation; });
  REQUIRE(rotation != skin.animations[0].channels.end());
  CHECK(rotation->node == 2);
  CHECK(rotation->times.size() == 12);

  // Both survive the wire unchanged.
  for (const scene::Scene* s : {&cube, &skin}) {
    const scene::Scene back = loader::decodeScene(loader::encodeScene(*s));
    test::requireSameScene(back, *s);
    REQUIRE(back.nodes.size() == s->nodes.size());
    CHECK(back.skins.size() == s->skins.size());
    REQUIRE(back.animations.size() == s->animations.size());
    CHECK(back.animations[0].channels[0].values == s->animations[0].channels[0].values);
    CHECK(back.meshes[0].morphTargets.size() == s->meshes[0].morphTargets.size());
    CHECK(back.meshes[0].joints == s->meshes[0].joints);
    for (size_t i = 0; i < s->instances.size(); ++i) {
      CHECK(back.instances[i].node == s->instances[i].node);
      CHECK(back.instances[i].skin == s->instances[i].skin);
    }
  }
}

TEST_CASE("animation: Collada and FBX skeletal animations load") {
  const scene::Scene dae = scene::loadModel(kModels / "Collada/box_nested_animation.dae");
  REQUIRE(dae.animations.size() == 1);
  CHECK(dae.skins.size() == 1);
  CHECK(dae.animations[0].duration == doctest::Approx(1.6667f).epsilon(1e-3));
  const scene::Scene fbx = scene::loadModel(kModels / "FBX/huesitos.fbx");
  REQUIRE(fbx.animations.size() == 1);
  REQUIRE(fbx.skins.size() == 1);
  CHECK(fbx.skins[0].joints.size() == 9);
  // 39 ticks at 25 per second.
  CHECK(fbx.animations[0].duration == doctest::Approx(39.0f / 25.0f));
  // A bone naming no node (Assimp's X importer): that mesh is drawn unskinned, not refused.
  const scene::Scene x = scene::loadModel(kModels / "X/anim_test.x");
  CHECK(x.skins.empty());
  CHECK_FALSE(x.instances.empty());
  // Posing at any time gives finite vertices.
  const auto posed = scene::poseInstances(fbx, 0, 0.7, true);
  REQUIRE_FALSE(posed.empty());
  const auto& inst = fbx.instances[posed[0].instance];
  for (const scene::Vertex& v : scene::poseVertices(fbx.meshes[inst.mesh], posed[0].joints, {})) {
    REQUIRE(std::isfinite(v.position.x + v.position.y + v.position.z));
  }
}

TEST_CASE("animation: hostile animation data is refused, naming it") {
  // Through the loader child: NaN key values, NaN key times.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  CHECK(loadRejection(animatedTriangle({0, 1}, {0, 0, 0, nan, 0, 0}), "nan.gltf")
            .find("non-finite key") != std::string::npos);
  CHECK(loadRejection(animatedTriangle({0, nan}, {0, 0, 0, 1, 0, 0}), "nan-time.gltf")
            .find("non-finite key") != std::string::npos);
  CHECK(loadRejection(animatedTriangle({0, 1}, {0, 0, 0, 1, 0, 0}), "fine.gltf") == "");

  // A sampler claiming 2^28 keys (about 1 GB of times and values) over a buffer of a few bytes:
  // refused, naming it, without the memory.
  {
    std::string claim = animatedTriangle({0, 1}, {0, 0, 0, 1, 0, 0});
    const std::string count = "\"count\":2,\"type\":\"SCALAR\"";
    const size_t at = claim.find(count);
    REQUIRE(at != std::string::npos);
    claim.replace(at, count.size(), "\"count\":268435456,\"type\":\"SCALAR\"");
    const std::string refused = loadRejection(claim, "claim.gltf");
    CAPTURE(refused);
    CHECK_FALSE(refused.empty());
    CHECK(refused.find("claim.gltf") != std::string::npos);
  }

  // On the wire, from a child that lies: a cycle of parents, a joint out of range, a NaN key,
  // a key count past the bytes, a channel naming a node that does not exist.
  scene::Scene s = twoJointScene();
  s.camera = scene::Camera{};
  REQUIRE(wireRejection(s) == "");
  {
    scene::Scene bad = s;
    bad.nodes[0].parent = 1;  // 0 -> 1 -> 0
    CHECK(wireRejection(bad).find("cycle of parents") != std::string::npos);
  }
  {
    scene::Scene bad = s;
    bad.meshes[0].joints[0].x = 7;
    CHECK(wireRejection(bad).find("joint out of range") != std::string::npos);
  }
  {
    scene::Scene bad = s;
    bad.animations[0].channels[0].values[4] = nan;
    CHECK(wireRejection(bad).find("non-finite") != std::string::npos);
  }
  {
    scene::Scene bad = s;
    bad.meshes[0].joints.clear();  // a skin on a mesh without joints
    bad.meshes[0].weights.clear();
    CHECK(wireRejection(bad).find("has no joints") != std::string::npos);
  }
  {
    scene::Scene bad = s;
    bad.animations[0].channels[0].node = 99;
    CHECK(wireRejection(bad).find("node the model does not have") != std::string::npos);
  }
  {
    scene::Scene bad = s;
    bad.animations[0].channels[0].times = {1, 0.5f};
    CHECK(wireRejection(bad).find("do not increase") != std::string::npos);
  }
  {
    // A sampler claiming 2^28 keys (a "1 GB" claim): refused from the count, before any
    // allocation, since the bytes cannot hold it.
    std::string wire = loader::encodeScene(s);
    const std::string name = "bend";
    const size_t at = wire.rfind(name);
    REQUIRE(at != std::string::npos);
    // After the name: duration (4), channel count (4), node (4), path, interpolation, keys.
    const size_t keys = at + name.size() + 4 + 4 + 4 + 2;
    const uint32_t huge = 1u << 28;
    std::memcpy(wire.data() + keys, &huge, 4);
    try {
      loader::decodeScene(wire);
      FAIL("decoded");
    } catch (const loader::SceneWireError& e) {
      CHECK(std::string(e.what()).find("limit") != std::string::npos);
    }
  }
}

TEST_CASE("animation: glTF step and cubic-spline samplers keep their interpolation") {
  // STEP: Assimp alone would interpolate linearly between the keys.
  const std::string step = animatedTriangle({0, 1, 2}, {0, 0, 0, 1, 0, 0, 4, 0, 0}, "STEP");
  const scene::Scene stepped = loader::loadModelBytes(step, "step.gltf");
  REQUIRE(stepped.animations.size() == 1);
  CHECK(stepped.animations[0].name == "move");
  REQUIRE(stepped.animations[0].channels.size() == 1);
  const scene::AnimationChannel& s = stepped.animations[0].channels[0];
  CHECK(s.interpolation == scene::Interpolation::step);
  CHECK(sample3(s, 1.5).x == 1.0f);
  // CUBICSPLINE: in-tangent, value, out-tangent per key, as in the hand-computed case above.
  const std::string cubic = animatedTriangle(
      {0, 2}, {0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 1, 0, 0, 9, 0, 0}, "CUBICSPLINE");
  const scene::Scene splined = loader::loadModelBytes(cubic, "cubic.gltf");
  REQUIRE(splined.animations.size() == 1);
  const scene::AnimationChannel& c = splined.animations[0].channels[0];
  CHECK(c.interpolation == scene::Interpolation::cubicSpline);
  CHECK(c.values.size() == 18);
  CHECK(sample3(c, 1.0).x == doctest::Approx(1.0f));
  // Key times that go backwards are refused, naming them.
  const std::string back =
      loadRejection(animatedTriangle({0, 2, 1}, {0, 0, 0, 1, 0, 0, 2, 0, 0}), "back.gltf");
  CAPTURE(back);
  // (Assimp's own validation sees it first here: a key past the duration it computed.)
  CHECK((back.find("do not increase") != std::string::npos ||
         back.find("mTime") != std::string::npos));
}

TEST_CASE("animation: coincident vertices with different joints or morph displacements stay apart") {
  // Two triangles, not indexed: corner 0 and corner 3 coincide but differ in their joint (a
  // seam) and in their morph displacement. Assimp's JoinIdenticalVertices would merge them.
  test::GltfBuilder b;
  const int pos = b.positions({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0});
  const int delta = b.floats({0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}, "VEC3", 3);
  const int joints = b.accessor(
      std::vector<uint16_t>{0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      "VEC4", 5123, 6);
  const int weights = b.floats(
      {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}, "VEC4", 4);
  const int ibm = b.floats({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1},
                           "MAT4", 16);
  b.nodes.push_back("{\"children\":[1,2,3]}");
  b.nodes.push_back("{\"mesh\":0,\"skin\":0}");
  b.nodes.push_back("{\"name\":\"j0\"}");
  b.nodes.push_back("{\"name\":\"j1\",\"translation\":[0,0,1]}");
  b.skins.push_back("{\"joints\":[2,3],\"inverseBindMatrices\":" + std::to_string(ibm) + "}");
  b.meshes.push_back("{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                     ",\"JOINTS_0\":" + std::to_string(joints) + ",\"WEIGHTS_0\":" +
                     std::to_string(weights) + "},\"targets\":[{\"POSITION\":" +
                     std::to_string(delta) + "}]}],\"weights\":[1]}");
  const scene::Scene s = loader::loadModelBytes(b.json(), "seam.gltf");
  REQUIRE(s.meshes.size() == 1);
  const scene::Mesh& mesh = s.meshes[0];
  REQUIRE(mesh.vertices.size() == 6);
  REQUIRE(mesh.morphTargets.size() == 1);
  REQUIRE(mesh.morphTargets[0].positions.size() == 6);
  CHECK(mesh.morphTargets[0].positions[0] == glm::vec3(0, 0, 1));
  CHECK(mesh.morphTargets[0].positions[3] == glm::vec3(0, 0, 0));
  CHECK(mesh.joints[0].x == 0);
  CHECK(mesh.joints[3].x == 1);
}

TEST_CASE("animation: a pose that overflows stays finite") {
  // Finite keys whose product overflows: a scale of 1e30 on a parent scaled 1e30.
  scene::Scene s;
  s.nodes.push_back({"big", -1, {}, {1, 0, 0, 0}, {1, 1, 1}});
  s.nodes.push_back({"bigger", 0, {}, {1, 0, 0, 0}, {1, 1, 1}});
  scene::Mesh mesh;
  mesh.vertices.resize(3);
  mesh.indices = {0, 1, 2};
  mesh.joints.assign(3, glm::uvec4(0));
  mesh.weights.assign(3, glm::vec4(1, 0, 0, 0));
  s.meshes.push_back(mesh);
  s.skins.push_back({"skin", {1}, {glm::mat4(1.0f)}});
  scene::Instance instance;
  instance.node = 1;
  instance.skin = 0;
  s.instances.push_back(instance);
  scene::Animation clip;
  clip.duration = 1.0f;
  for (uint32_t node : {0u, 1u}) {
    clip.channels.push_back({node, scene::AnimationPath::scale, scene::Interpolation::linear,
                             {0, 1}, {1e30f, 1e30f, 1e30f, 1e30f, 1e30f, 1e30f}});
  }
  s.animations.push_back(clip);
  REQUIRE_FALSE(scene::checkAnimationData(s).has_value());
  const auto posed = scene::poseInstances(s, 0, 0.5, false);
  REQUIRE(posed.size() == 1);
  REQUIRE(posed[0].joints.size() == 1);
  CHECK(posed[0].joints[0] == glm::mat4(1.0f));
}
