// myriad-skin-bench: the GPU time of the skinning pre-pass (render/skinning.h, the "skin" pass)
// for many skinned characters posed anew every frame (issue 29: 100 characters of 10k vertices
// each). GPU timestamps, the median after warm-up; docs/performance.md says how it is run.
//
//   myriad-skin-bench [--characters N] [--vertices N] [--joints N] [--frames N] [--warmup N]
//                     [--width W] [--height H] [--device INDEX|NAME] [--validate] [--json PATH]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "gpu/context.h"
#include "render/renderer.h"

using namespace myriad;

namespace {

struct Options {
  uint32_t characters = 100;
  uint32_t vertices = 10000;  // per character (rounded to whole rings of kAround)
  uint32_t joints = 64;
  uint32_t frames = 60;
  uint32_t warmup = 10;
  uint32_t width = 1280;
  uint32_t height = 720;
  std::string device;
  bool validate = false;
  std::string json;
  render::Tuning tuning;  // --tune key=value, repeatable (render/tuning.h)
};

constexpr uint32_t kAround = 40;  // vertices around a ring
constexpr float kHeight = 1.8f;    // a character's height (its joints stacked along +y)

// A character: a tube kHeight tall whose radius varies along it, `joints` joints stacked along
// +y, each vertex weighing the four joints nearest its height (4 influences, weights summing to 1).
scene::Mesh character(uint32_t vertices, uint32_t joints) {
  scene::Mesh m;
  m.name = "character";
  const uint32_t rings = std::max(2u, vertices / kAround);
  for (uint32_t r = 0; r < rings; ++r) {
    const float y = kHeight * float(r) / float(rings - 1);
    const float radius = 0.18f + 0.06f * std::sin(y * 5.0f);
    const float at = y / kHeight * float(joints) - 0.5f;  // in joint spacings
    for (uint32_t a = 0; a < kAround; ++a) {
      const float angle = 6.2831853f * float(a) / float(kAround);
      scene::Vertex v;
      v.normal = glm::vec3(std::cos(angle), 0.0f, std::sin(angle));
      v.position = glm::vec3(radius * v.normal.x, y, radius * v.normal.z);
      v.uv = glm::vec2(float(a) / float(kAround), y / kHeight);
      v.tangent = glm::vec4(-std::sin(angle), 0.0f, std::cos(angle), 1.0f);
      m.vertices.push_back(v);
      glm::uvec4 j;
      glm::vec4 w;
      float sum = 0.0f;
      const int first = int(std::floor(at)) - 1;
      for (int i = 0; i < 4; ++i) {
        const int k = std::clamp(first + i, 0, int(joints) - 1);
        j[i] = uint32_t(k);
        w[i] = std::max(0.0f, 2.0f - std::abs(float(first + i) - at));
        sum += w[i];
      }
      m.joints.push_back(j);
      m.weights.push_back(w / sum);
    }
  }
  for (uint32_t r = 0; r + 1 < rings; ++r) {
    for (uint32_t a = 0; a < kAround; ++a) {
      const uint32_t i0 = r * kAround + a, i1 = r * kAround + (a + 1) % kAround;
      m.indices.insert(m.indices.end(), {i0, i0 + kAround, i1, i1, i0 + kAround, i1 + kAround});
    }
  }
  return m;
}

scene::Scene crowd(const Options& o) {
  scene::Scene s;
  s.meshes = {character(o.vertices, o.joints)};
  s.materials.push_back({"skin", glm::vec3(0.8f, 0.6f, 0.5f), 0.0f, 0.6f});
  scene::Skin skin;
  for (uint32_t k = 0; k < o.joints; ++k) {
    scene::Node n;
    n.parent = k == 0 ? -1 : int32_t(k - 1);
    n.translation = glm::vec3(0.0f, k == 0 ? 0.0f : kHeight / float(o.joints), 0.0f);
    s.nodes.push_back(n);
    skin.joints.push_back(k);
    skin.inverseBind.push_back(
        glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, -kHeight * float(k) / float(o.joints), 0.0f)));
  }
  s.skins.push_back(skin);
  const uint32_t side = uint32_t(std::ceil(std::sqrt(double(o.characters))));
  for (uint32_t i = 0; i < o.characters; ++i) {
    const glm::vec3 place(float(i % side) - 0.5f * float(side), 0.0f, -float(i / side) * 1.0f);
    scene::Instance instance{0, 0, glm::translate(glm::mat4(1.0f), place)};
    instance.object = i + 1;
    instance.skin = 0;
    s.instances.push_back(instance);
  }
  s.camera.eye = glm::vec3(0.0f, 6.0f, 8.0f);
  s.camera.target = glm::vec3(0.0f, 0.5f, -0.5f * float(side));
  s.camera.farPlane = 100.0f;
  return s;
}

// Every character swaying differently at `frame`: each joint bent about x and z relative to its
// parent.
std::shared_ptr<render::ScenePose> poseAt(const Options& o, uint32_t frame) {
  auto pose = std::make_shared<render::ScenePose>();
  pose->time = frame / 30.0;
  for (uint32_t c = 0; c < o.characters; ++c) {
    render::InstancePose p;
    p.instance = c;
    glm::mat4 world(1.0f);
    for (uint32_t k = 0; k < o.joints; ++k) {
      if (k > 0) world = glm::translate(world, glm::vec3(0.0f, kHeight / float(o.joints), 0.0f));
      const float phase = 0.1f * float(frame) + 0.37f * float(c) + 0.05f * float(k);
      world = glm::rotate(world, 0.6f / float(o.joints) * std::sin(phase), glm::vec3(1, 0, 0));
      world = glm::rotate(world, 0.4f / float(o.joints) * std::cos(phase), glm::vec3(0, 0, 1));
      p.joints.push_back(world * glm::translate(glm::mat4(1.0f),
                                                glm::vec3(0.0f, -kHeight * float(k) / float(o.joints), 0.0f)));
    }
    pose->poses.push_back(std::move(p));
  }
  return pose;
}

uint32_t number(std::string_view flag, const char* value) {
  char* end = nullptr;
  const unsigned long n = std::strtoul(value, &end, 10);
  if (end == value || *end != '\0' || n == 0 || n > 1000000) {
    throw std::invalid_argument(std::string(flag) + " expects a positive whole number.");
  }
  return uint32_t(n);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view flag = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(flag) + " expects a value.");
      return argv[++i];
    };
    if (flag == "--characters") o.characters = number(flag, value());
    else if (flag == "--vertices") o.vertices = number(flag, value());
    else if (flag == "--joints") o.joints = number(flag, value());
    else if (flag == "--frames") o.frames = number(flag, value());
    else if (flag == "--warmup") o.warmup = number(flag, value());
    else if (flag == "--width") o.width = number(flag, value());
    else if (flag == "--height") o.height = number(flag, value());
    else if (flag == "--device") o.device = value();
    else if (flag == "--json") o.json = value();
    else if (flag == "--validate") o.validate = true;
    else if (flag == "--tune") render::applyTune(o.tuning, value());
    else throw std::invalid_argument("unknown flag " + std::string(flag) + ".");
  }
  return o;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  return v[size_t(q * double(v.size() - 1) + 0.5)];
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    o = parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-skin-bench: %s\n", e.what());
    return 2;
  }
  try {
    auto context = gpu::createContext({.validation = o.validate,
                                       .device = o.device,
                                       .pipelineStatistics = o.tuning.pipelineStatistics});
    if (!context->info.timestampsSupported) {
      std::fprintf(stderr, "myriad-skin-bench: %s has no timestamp queries.\n", context->info.name.c_str());
      return 1;
    }
    render::Renderer renderer(*context, o.tuning);
    const scene::Scene scene = crowd(o);
    const uint32_t verticesEach = uint32_t(scene.meshes[0].vertices.size());
    const render::SceneId id = renderer.createScene(scene);
    render::FrameSettings f;
    f.width = o.width;
    f.height = o.height;
    f.camera = scene.camera;
    f.markers = false;
    f.takeLightingFrom(scene);
    std::vector<double> skin, frame;
    for (uint32_t i = 0; i < o.warmup + o.frames; ++i) {
      f.pose = poseAt(o, i);
      const render::Frame out = renderer.render(id, f);
      double ms = -1.0;
      for (const render::PassTiming& p : out.passes) {
        if (p.name == "skin") ms = p.milliseconds;
      }
      if (ms < 0.0) throw std::runtime_error("frame " + std::to_string(i) + " has no skin pass");
      if (i >= o.warmup) {
        skin.push_back(ms);
        frame.push_back(out.times.gpuMs);
      }
    }
    const uint64_t posed = uint64_t(verticesEach) * o.characters;
    std::printf("device: %s\n", context->info.name.c_str());
    std::printf("%u characters x %u vertices (%llu posed), %u joints, 4 influences; %u frames after %u\n",
                o.characters, verticesEach, (unsigned long long)posed, o.joints, o.frames, o.warmup);
    std::printf("skin pass: median %.4f ms, p10 %.4f, p90 %.4f (%.1f Mvertices/s); frame median %.3f ms\n",
                percentile(skin, 0.5), percentile(skin, 0.1), percentile(skin, 0.9),
                double(posed) / (percentile(skin, 0.5) * 1e3), percentile(frame, 0.5));
    if (!o.json.empty()) {
      nlohmann::json j = {{"device", context->info.name},
                          {"characters", o.characters},
                          {"verticesEach", verticesEach},
                          {"joints", o.joints},
                          {"frames", o.frames},
                          {"warmup", o.warmup},
                          {"width", o.width},
                          {"height", o.height},
                          {"skinMs", {{"median", percentile(skin, 0.5)},
                                      {"p10", percentile(skin, 0.1)},
                                      {"p90", percentile(skin, 0.9)},
                                      {"samples", skin}}},
                          {"frameGpuMsMedian", percentile(frame, 0.5)},
                          {"validationMessages", context->validationMessages.load()}};
      std::ofstream(o.json) << j.dump(2) << '\n';
    }
    if (o.validate && context->validationMessages.load() != 0) {
      std::fprintf(stderr, "myriad-skin-bench: %llu validation messages\n",
                   (unsigned long long)context->validationMessages.load());
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "myriad-skin-bench: %s\n", e.what());
    return 1;
  }
}
