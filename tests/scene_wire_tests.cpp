// The loader's wire format: what the parent accepts from a child it does not trust.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "loader/scene_wire.h"
#include "loader_support.h"
#include "scene/model_loader.h"

using namespace myriad;
using test::requireSameScene;

namespace {

const std::filesystem::path kModels = test::assimpModels();

}  // namespace

TEST_CASE("wire: corrupted wire data is rejected") {
  const scene::Scene original = scene::loadModel(kModels / "OBJ/spider.obj");
  const std::string wire = loader::encodeScene(original);
  requireSameScene(loader::decodeScene(wire), original);

  auto rejects = [](const std::string& bytes) {
    try {
      loader::decodeScene(bytes);
      return false;
    } catch (const loader::SceneWireError&) {
      return true;
    }
  };
  // Every truncation (sampled), and one byte too many.
  int truncations = 0;
  for (size_t length = 0; length < wire.size(); length += 1 + length / 64) {
    CAPTURE(length);
    CHECK(rejects(wire.substr(0, length)));
    ++truncations;
  }
  CHECK(rejects(wire + '\0'));

  auto patched = [&](size_t offset, uint32_t value) {
    std::string bytes = wire;
    std::memcpy(bytes.data() + offset, &value, 4);
    return bytes;
  };
  CHECK(rejects(patched(0, 0x12345678)));  // magic
  CHECK(rejects(patched(4, loader::kSceneWireVersion + 1)));  // version
  // Counts of meshes, materials, instances, lights, images: one more, one fewer, and absurd.
  for (size_t offset : {8, 12, 16, 20, 24}) {
    uint32_t count;
    std::memcpy(&count, wire.data() + offset, 4);
    CAPTURE(offset);
    CHECK(rejects(patched(offset, count + 1)));
    if (count > 0) CHECK(rejects(patched(offset, count - 1)));
    CHECK(rejects(patched(offset, 0xFFFFFFFFu)));
  }

  // Inside the body: the first mesh's vertex count, an index, a NaN position.
  scene::Scene broken = original;
  broken.meshes[0].indices[5] = uint32_t(broken.meshes[0].vertices.size());
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.meshes[0].vertices[3].position.y = std::nanf("");
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.instances[0].mesh = uint32_t(broken.meshes.size());
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.instances[0].transform[3][1] = INFINITY;
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.materials[0].roughness = 2.0f;
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.meshes[0].indices.pop_back();  // not a whole number of triangles
  CHECK(rejects(loader::encodeScene(broken)));
  // Images: the spider's textures are on the wire; their sizes and indices are checked.
  REQUIRE(!original.images.empty());
  broken = original;
  broken.images[0].rgba.pop_back();  // fewer bytes than width x height x 4
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.images[0].width = 9000;  // over the texture dimension limit
  broken.images[0].rgba.resize(size_t(9000) * broken.images[0].height * 4);
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.materials[0].baseColorTexture.image = uint32_t(original.images.size());  // no such image
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.materials[0].baseColorTexture.sampler.wrapS = scene::Sampler::Wrap(7);
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.meshes[0].vertices[0].tangent = glm::vec4(2.0f, 0.0f, 0.0f, 1.0f);  // not a unit vector
  CHECK(rejects(loader::encodeScene(broken)));
  broken = original;
  broken.meshes[0].vertices[0].color = glm::vec4(1.5f);  // out of range
  CHECK(rejects(loader::encodeScene(broken)));

  // Names: not UTF-8 and control characters are replaced, never passed on.
  broken = original;
  broken.materials[0].name = "a\xff\xc0\x80z\n\x1b";
  const scene::Scene cleaned = loader::decodeScene(loader::encodeScene(broken));
  CHECK(cleaned.materials[0].name == "a???z  ");
  broken.materials[0].name = "Ünïcödé ✓";
  CHECK(loader::decodeScene(loader::encodeScene(broken)).materials[0].name == "Ünïcödé ✓");
  MESSAGE(truncations, " truncations rejected");
}

TEST_CASE("wire: randomly corrupted wire data is rejected or still consistent") {
  // Without its texture images: their pixels are most of the bytes and any value is a pixel, so
  // corruption there proves nothing (the images' sizes and indices are checked in the case above).
  scene::Scene spider = scene::loadModel(kModels / "OBJ/spider.obj");
  spider.images.clear();
  for (scene::Material& m : spider.materials) {
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) m.texture(slot) = {};
  }
  const std::string wire = loader::encodeScene(spider);
  uint64_t state = 0x9E3779B97F4A7C15ull;  // fixed seed: a failure reproduces
  auto next = [&state] {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;
    return state;
  };
  int rejected = 0, accepted = 0, violations = 0;
  for (int round = 0; round < 3000; ++round) {
    std::string bytes = wire;
    const int flips = 1 + int(next() % 4);
    for (int f = 0; f < flips; ++f) {
      // Mostly the header and the first records, where counts and sizes live.
      const size_t at = next() % (round % 2 ? bytes.size() : std::min<size_t>(bytes.size(), 256));
      bytes[at] = char(next());
    }
    try {
      const scene::Scene scene = loader::decodeScene(bytes);
      ++accepted;
      // What is accepted must be safe to render: every reference in range, every number finite.
      for (const scene::Instance& instance : scene.instances) {
        violations += instance.mesh >= scene.meshes.size();
        violations += instance.material >= scene.materials.size();
      }
      for (const scene::Mesh& mesh : scene.meshes) {
        violations += mesh.indices.size() % 3 != 0;
        for (uint32_t index : mesh.indices) violations += index >= mesh.vertices.size();
        for (const scene::Vertex& v : mesh.vertices) {
          violations += !std::isfinite(v.position.x + v.position.y + v.position.z);
        }
      }
    } catch (const loader::SceneWireError&) {
      ++rejected;
    }
  }
  MESSAGE(rejected, " corruptions rejected, ", accepted, " decoded to a consistent scene");
  CHECK(violations == 0);
  CHECK(rejected > 1000);
}


TEST_CASE("wire: spot lights, extra suns and cameras cross intact; broken ones are rejected") {
  scene::Scene original = scene::loadModel(kModels / "OBJ/spider.obj");
  scene::PointLight spot;
  spot.position = glm::vec3(1.0f, 2.0f, 3.0f);
  spot.radius = 5.0f;
  spot.intensity = 40.0f;
  spot.type = scene::LightType::Spot;
  spot.attenuation = scene::Attenuation::InverseSquare;
  spot.direction = glm::normalize(glm::vec3(0.3f, -1.0f, 0.2f));
  spot.innerConeAngle = 0.2f;
  spot.outerConeAngle = 0.5f;
  original.lights = {scene::PointLight{}, spot};
  original.extraSuns = {scene::Sun{}, scene::Sun{glm::vec3(0.0f, -1.0f, 0.0f), glm::vec3(1.0f, 0.5f, 0.5f), 3.0f}};
  original.droppedSuns = 2;
  scene::ModelCamera camera;
  camera.name = "overhead";
  camera.yfov = 0.7f;
  camera.aspectRatio = 1.5f;
  camera.znear = 0.05f;
  camera.zfar = 40.0f;
  camera.position = glm::vec3(0.0f, 5.0f, 0.0f);
  camera.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  camera.up = glm::vec3(0.0f, 0.0f, -1.0f);
  original.cameras = {camera};
  original.ignoredExtensions = {"KHR_materials_sheen", "KHR_texture_basisu"};
  original.materials.at(0).unlit = true;
  original.materials.at(0).clearcoat = 0.75f;
  original.materials.at(0).clearcoatRoughness = 0.125f;
  original.materials.at(0).sheenColor = glm::vec3(0.5f, 0.25f, 1.0f);
  original.materials.at(0).sheenRoughness = 0.375f;
  requireSameScene(loader::decodeScene(loader::encodeScene(original)), original);

  auto rejected = [](const scene::Scene& s) -> std::string {
    try {
      loader::decodeScene(loader::encodeScene(s));
      return "";
    } catch (const loader::SceneWireError& e) {
      return e.what();
    }
  };
  auto withSpot = [&](auto change) {
    scene::Scene s = original;
    change(s.lights[1]);
    return rejected(s);
  };
  CHECK(withSpot([](scene::PointLight& l) { l.innerConeAngle = 0.5f; }).find("inner >= outer") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.outerConeAngle = 1.6f; }).find("outer cone") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.innerConeAngle = -0.1f; }).find("inner cone") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.direction = glm::vec3(0.0f, -2.0f, 0.0f); }).find("unit") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.direction.x = std::nanf(""); }).find("non-finite") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.type = scene::LightType(7); }).find("light type") != std::string::npos);
  CHECK(withSpot([](scene::PointLight& l) { l.attenuation = scene::Attenuation(9); }).find("attenuation") != std::string::npos);
  scene::Scene suns = original;
  suns.extraSuns.assign(4, scene::Sun{});
  CHECK(rejected(suns).find("directional") != std::string::npos);
  suns = original;
  suns.extraSuns[1].intensity = 5000.0f;
  CHECK(rejected(suns).find("intensity") != std::string::npos);
  scene::Scene cameras = original;
  cameras.cameras[0].up = glm::vec3(0.0f, -1.0f, 0.0f);  // along the direction
  CHECK(rejected(cameras).find("perpendicular") != std::string::npos);
  cameras = original;
  cameras.cameras[0].zfar = 0.01f;
  CHECK(rejected(cameras).find("planes") != std::string::npos);
  cameras = original;
  cameras.cameras[0].yfov = 0.0f;
  CHECK(rejected(cameras).find("field of view") != std::string::npos);
  scene::Scene layers = original;
  layers.materials[0].clearcoat = 1.5f;
  CHECK(rejected(layers).find("clearcoat factor") != std::string::npos);
  layers = original;
  layers.materials[0].sheenColor.g = -0.25f;
  CHECK(rejected(layers).find("sheen colour") != std::string::npos);
}
