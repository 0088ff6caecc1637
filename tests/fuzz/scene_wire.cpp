// The scene wire decoder (server/loader/scene_wire.h): what the server reads back from a loader
// child, which it must treat as hostile (a model may have taken the child over).
//
// Input: the bytes of a reply body.
// Promises checked: decodeScene throws only SceneWireError; a scene it accepts has every index in
// range, every number finite, names of at most kMaxWireNameBytes bytes of printable UTF-8,
// animation data within scene/animation.h's rules and posable, and survives encode -> decode
// unchanged.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_support.h"
#include "loader/scene_wire.h"
#include "scene/animation.h"

namespace loader = myriad::loader;
namespace scene = myriad::scene;
using myriad::fuzz::require;

namespace {

bool finite(float f) { return std::isfinite(f); }
template <int N>
bool finite(const glm::vec<N, float>& v) {
  for (int i = 0; i < N; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

void checkName(const std::string& name) {
  require(name.size() <= loader::kMaxWireNameBytes, "a name longer than the limit");
  require(loader::cleanText(name) == name, "a name that cleanText would change");
}

void checkScene(const scene::Scene& s) {
  for (const scene::Mesh& mesh : s.meshes) {
    checkName(mesh.name);
    require(mesh.indices.size() % 3 == 0, "a mesh whose index count is not whole triangles");
    for (uint32_t index : mesh.indices) require(index < mesh.vertices.size(), "an index out of range");
    for (const scene::Vertex& v : mesh.vertices) {
      require(finite(v.position) && finite(v.normal) && finite(v.uv), "a vertex not finite");
    }
  }
  for (const scene::Material& m : s.materials) {
    checkName(m.name);
    require(finite(m.baseColor) && finite(m.metallic) && finite(m.roughness),
            "a material not finite");
  }
  for (const scene::Instance& instance : s.instances) {
    require(instance.mesh < s.meshes.size(), "an instance of a mesh that is not there");
    require(instance.material < s.materials.size(), "an instance with a material not there");
    for (int c = 0; c < 4; ++c) require(finite(instance.transform[c]), "a transform not finite");
  }
  for (const scene::PointLight& l : s.lights) {
    require(finite(l.position) && finite(l.radius) && finite(l.color) && finite(l.intensity) &&
                finite(l.falloff),
            "a light not finite");
  }
  require(finite(s.sun.direction) && finite(s.sun.color) && finite(s.sun.intensity),
          "the sun not finite");
  require(finite(s.ambient) && finite(s.background), "ambient or background not finite");
  const scene::Camera& c = s.camera;
  require(finite(c.eye) && finite(c.target) && finite(c.up) && finite(c.fovYDegrees) &&
              finite(c.nearPlane) && finite(c.farPlane),
          "the camera not finite");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  scene::Scene decoded;
  try {
    decoded = loader::decodeScene(bytes);
  } catch (const loader::SceneWireError& e) {
    require(std::string_view(e.what()).size() > 0, "a refusal without a reason");
    return 0;
  }
  checkScene(decoded);
  // Animation data the decoder accepted keeps scene/animation.h's rules, and posing it (clips
  // and the rest pose, looped past their ends) neither faults nor leaves an index unchecked.
  require(!scene::checkAnimationData(decoded), "accepted animation data that breaks the rules");
  for (int clip = -1; clip < int(std::min<size_t>(decoded.animations.size(), 3)); ++clip) {
    for (const scene::PosedInstance& posed : scene::poseInstances(decoded, clip, 1.37, true)) {
      require(posed.instance < decoded.instances.size(), "a pose of an instance not there");
      const scene::Instance& instance = decoded.instances[posed.instance];
      if (instance.mesh < decoded.meshes.size() && decoded.meshes[instance.mesh].vertices.size() <= 4096) {
        scene::poseVertices(decoded.meshes[instance.mesh], posed.joints, posed.morphWeights);
      }
    }
  }
  // What the decoder accepted, the encoder writes back in a form the decoder accepts again.
  const std::string again = loader::encodeScene(decoded);
  require(loader::encodeScene(loader::decodeScene(again)) == again, "encode/decode not stable");
  return 0;
}
