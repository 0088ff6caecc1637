// The G-buffer rasterised in compute (render/visibility.h) against the raster path, on lavapipe
// with validation on: every G-buffer view and the final image the same within 1/255 except a
// bounded number of pixels on silhouette edges, depth within a small relative epsilon, the
// techniques still agreeing, the raster path taken where a scene does not qualify.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "bench/bench_scene.h"
#include "gpu_test_support.h"
#include "image_compare.h"
#include "render/renderer.h"
#include "scene/builtin_scene.h"
#include "scene/primitives.h"

using namespace myriad;
using render::GBufferPath;
using render::Target;

namespace {

test::GpuSuite& sharedGpu() {
  static test::GpuSuite gpu = test::createGpuSuite();
  return gpu;
}

bool hasPass(const render::Frame& frame, const std::string& name) {
  return std::any_of(frame.passes.begin(), frame.passes.end(),
                     [&](const render::PassTiming& p) { return p.name == name; });
}

render::Frame renderWith(GBufferPath path, render::FrameSettings f) {
  test::GpuSuite& gpu = sharedGpu();
  gpu.renderer->setGBufferPath(path);
  render::Frame frame = gpu.renderer->render(gpu.scene, f);
  gpu.renderer->setGBufferPath(GBufferPath::Raster);
  // Which path ran, from the frame's own pass names.
  const bool compute = path == GBufferPath::Compute;
  CHECK(hasPass(frame, "gbuffer") == !compute);
  CHECK(hasPass(frame, "visibility") == compute);
  CHECK(hasPass(frame, "resolve") == compute);
  return frame;
}

// Pixels whose 4-neighbourhood in the raster path's raw depth view changes by more than 2% (a
// silhouette: one surface in front of another, or geometry against the background).
std::vector<uint8_t> silhouettePixels(const render::Frame& depth) {
  const int w = int(depth.width);
  const int h = int(depth.height);
  std::vector<uint8_t> edge(size_t(w) * h, 0);
  auto z = [&](int x, int y) { return depth.data[(size_t(y) * w + x) * 4]; };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float here = z(x, y);
      for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const float there = z(nx, ny);
        if (std::abs(here - there) > 0.02f * std::max(std::abs(here), std::abs(there))) {
          edge[size_t(y) * w + x] = 1;
        }
      }
    }
  }
  return edge;
}

struct Comparison {
  size_t differing = 0;          // pixels over 1/255 in some channel
  size_t differingOffEdge = 0;   // of those, pixels not on a silhouette
  size_t silhouette = 0;         // silhouette pixels in the image
};

Comparison compare8(const render::Frame& raster, const render::Frame& compute,
                    const std::vector<uint8_t>& edge) {
  REQUIRE(raster.rgba.size() == compute.rgba.size());
  Comparison c;
  for (size_t i = 0; i < edge.size(); ++i) {
    c.silhouette += edge[i];
    bool differs = false;
    for (int k = 0; k < 4; ++k) {
      differs = differs || std::abs(int(raster.rgba[i * 4 + k]) - int(compute.rgba[i * 4 + k])) > 1;
    }
    if (differs) {
      ++c.differing;
      if (!edge[i]) ++c.differingOffEdge;
    }
  }
  return c;
}

// One scene, both paths: every G-buffer view, the raw depth and the final image.
void compareScene(const char* name, const scene::Scene& s, uint32_t width, uint32_t height,
                  render::Technique technique) {
  test::GpuSuite& gpu = sharedGpu();
  gpu.setScene(s);
  render::FrameSettings f;
  f.width = width;
  f.height = height;
  f.camera = s.camera;
  f.takeLightingFrom(s);
  f.markers = false;
  // Anti-aliasing off, as the technique tests have it: FXAA's edge test turns a 1-ulp
  // difference in luma into a blend or none.
  f.antialias = render::Antialias::None;
  f.technique = technique;

  // Depth, raw (view-space distance along the axis): equal within a relative 1e-3 except where
  // the two paths picked different surfaces (silhouettes).
  f.target = Target::Depth;
  f.raw = true;
  const render::Frame rasterDepth = renderWith(GBufferPath::Raster, f);
  const render::Frame computeDepth = renderWith(GBufferPath::Compute, f);
  const std::vector<uint8_t> edge = silhouettePixels(rasterDepth);
  size_t depthOff = 0, depthOffEdge = 0, covered = 0;
  for (size_t i = 0; i < edge.size(); ++i) {
    const float a = rasterDepth.data[i * 4], b = computeDepth.data[i * 4];
    REQUIRE(std::isfinite(b));
    covered += a < f.camera.farPlane ? 1 : 0;
    if (std::abs(a - b) > 1e-3f * std::max(a, b) + 1e-5f) {
      ++depthOff;
      if (!edge[i]) ++depthOffEdge;
    }
  }
  f.raw = false;
  const size_t pixels = size_t(width) * height;
  size_t silhouette = std::count(edge.begin(), edge.end(), uint8_t{1});
  MESSAGE(std::string(name) << ": " << covered << " of " << pixels << " pixels covered, " << silhouette
                << " on silhouettes; depth differs at " << depthOff << " (" << depthOffEdge
                << " off silhouettes)");
  CHECK(covered > pixels / 4);
  // Off silhouettes the two rasterisers cover the same pixel centres with the same surface:
  // a differing pixel there is a wrong pixel. On them, a pixel centre within rounding of an
  // edge may fall to either side (vertices snap to 1/256 pixel in both, but the viewport
  // transform and edge evaluation round differently): at most a twentieth of the silhouette
  // pixels (lavapipe: 0-2 of 3,600-5,700).
  CHECK(depthOffEdge == 0);
  CHECK(depthOff <= silhouette / 20 + 2);

  // Uv, raw: the 8-bit view shows fract(uv), where one half-float step of the RG16F target at
  // uv ~ 20 (1/64) is 4/255. Equal within two half-float steps.
  f.target = Target::Uv;
  f.raw = true;
  {
    const render::Frame raster = renderWith(GBufferPath::Raster, f);
    const render::Frame compute = renderWith(GBufferPath::Compute, f);
    size_t uvOff = 0, uvOffEdge = 0;
    for (size_t i = 0; i < edge.size(); ++i) {
      bool differs = false;
      for (int k = 0; k < 2; ++k) {
        const float a = raster.data[i * 4 + k], b = compute.data[i * 4 + k];
        differs = differs || std::abs(a - b) > std::max(1.0f, std::abs(a)) * (2.0f / 1024.0f);
      }
      uvOff += differs ? 1 : 0;
      uvOffEdge += differs && !edge[i] ? 1 : 0;
    }
    MESSAGE(std::string(name) << " uv (raw): " << uvOff << " pixels differ (" << uvOffEdge
                              << " off silhouettes)");
    CHECK(uvOffEdge == 0);
    CHECK(uvOff <= silhouette / 20 + 2);
  }
  f.raw = false;

  // The G-buffer views: equal within 1/255 off silhouettes.
  std::vector<uint8_t> albedoDiffers(edge.size(), 0);
  for (Target view : {Target::Albedo, Target::Normal, Target::Position, Target::Metallic,
                      Target::Roughness, Target::Emissive, Target::Occlusion}) {
    f.target = view;
    const render::Frame raster = renderWith(GBufferPath::Raster, f);
    const render::Frame compute = renderWith(GBufferPath::Compute, f);
    const Comparison c = compare8(raster, compute, edge);
    MESSAGE(std::string(name) << " " << render::targetName(view) << ": " << c.differing
                              << " pixels over 1/255 (" << c.differingOffEdge << " off silhouettes)");
    CHECK(c.differingOffEdge == 0);
    CHECK(c.differing <= silhouette / 20 + 2);
    if (view == Target::Albedo) {
      for (size_t i = 0; i < edge.size(); ++i) {
        for (int k = 0; k < 3; ++k) albedoDiffers[i] |= raster.rgba[i * 4 + k] != compute.rgba[i * 4 + k];
      }
    }
  }

  // The lit picture. The base colour target is sRGB: the raster path's store rounds with the
  // implementation's conversion (Vulkan allows it a tolerance; lavapipe's is an approximation),
  // the resolve pass encodes with the exact curve, so a base colour within that error of a
  // rounding boundary lands one code apart (the albedo view above allows it), and lighting
  // scales that code by the light reaching the pixel. Off silhouettes the picture is therefore
  // within 1/255, or within 4/255 where the base colour differs, at no more than 1% of pixels.
  f.target = Target::Final;
  {
    const render::Frame raster = renderWith(GBufferPath::Raster, f);
    const render::Frame compute = renderWith(GBufferPath::Compute, f);
    const Comparison c = compare8(raster, compute, edge);
    size_t fromBaseColor = 0, unexplained = 0;
    for (size_t i = 0; i < edge.size(); ++i) {
      if (edge[i]) continue;
      int worst = 0;
      for (int k = 0; k < 3; ++k) {
        worst = std::max(worst, std::abs(int(raster.rgba[i * 4 + k]) - int(compute.rgba[i * 4 + k])));
      }
      if (worst <= 1) continue;
      if (albedoDiffers[i] && worst <= 4) {
        ++fromBaseColor;
      } else {
        ++unexplained;
      }
    }
    MESSAGE(std::string(name) << " final: " << c.differing << " pixels over 1/255 ("
                              << c.differingOffEdge << " off silhouettes, " << fromBaseColor
                              << " of them where the base colour rounded apart)");
    CHECK(unexplained == 0);
    CHECK(fromBaseColor <= pixels / 100);
    CHECK(c.differing - c.differingOffEdge <= silhouette / 20 + 2);
  }

  // No NaN or Inf in what compute resolved: the raw final image.
  f.target = Target::Final;
  f.raw = true;
  const render::Frame raw = renderWith(GBufferPath::Compute, f);
  CHECK(std::all_of(raw.data.begin(), raw.data.end(), [](float v) { return std::isfinite(v); }));
}

}  // namespace

TEST_CASE("compute G-buffer: the floor scene (near-plane clipping, large triangles) matches raster") {
  scene::Scene s = bench::makeBenchScene({.kind = bench::BenchScene::Floor, .lightCount = 200});
  compareScene("floor", s, 192, 108, render::Technique::Clustered);
  CHECK(sharedGpu().context->validationMessages.load() == 0);
}

TEST_CASE("compute G-buffer: the built-in scene matches raster") {
  scene::Scene s = scene::makeBuiltinScene(64);
  compareScene("builtin", s, 160, 90, render::Technique::Tiled);
  CHECK(sharedGpu().context->validationMessages.load() == 0);
}

TEST_CASE("compute G-buffer: double-sided faces seen from behind, techniques agree") {
  // A double-sided plane seen from below (its back faces drawn, normals flipped) over a box.
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  scene::Material twoSided{"sheet", glm::vec3(0.3f, 0.6f, 0.9f), 0.2f, 0.5f};
  twoSided.doubleSided = true;
  s.materials.push_back(twoSided);
  s.materials.push_back({"box", glm::vec3(0.8f, 0.5f, 0.3f), 0.5f, 0.35f});
  s.instances.push_back({0, 0, glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 2.0f, 0.0f)),
                                          glm::vec3(8.0f, 1.0f, 8.0f))});
  s.instances.push_back({1, 1, glm::mat4(1.0f)});
  scene::PointLight light;
  light.position = glm::vec3(0.0f, 1.2f, 1.5f);
  light.radius = 4.0f;
  light.color = glm::vec3(1.0f, 0.8f, 0.6f);
  light.intensity = 4.0f;
  s.lights.push_back(light);
  s.camera.eye = glm::vec3(0.5f, 0.8f, 4.0f);
  s.camera.target = glm::vec3(0.0f, 1.5f, 0.0f);
  s.sun.intensity = 0.5f;
  compareScene("double-sided", s, 96, 64, render::Technique::Volumes);

  // The techniques light the compute path's G-buffer alike (as they do the raster path's).
  test::GpuSuite& gpu = sharedGpu();
  render::FrameSettings f;
  f.width = 96;
  f.height = 64;
  f.camera = s.camera;
  f.takeLightingFrom(s);
  f.markers = false;
  std::vector<render::Frame> frames;
  for (render::Technique t : render::allTechniques()) {
    f.technique = t;
    frames.push_back(renderWith(GBufferPath::Compute, f));
  }
  for (size_t i = 1; i < frames.size(); ++i) {
    CHECK(test::maxDifference(frames[0].rgba, frames[i].rgba) <= 1);
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}

TEST_CASE("compute G-buffer: a scene that does not qualify takes the raster path") {
  test::GpuSuite& gpu = sharedGpu();
  scene::Scene s = scene::makeBuiltinScene(8);
  s.materials[0].alphaMode = scene::AlphaMode::mask;  // alpha-tested: the raster path's
  gpu.setScene(s);
  render::FrameSettings f;
  f.width = 64;
  f.height = 48;
  f.camera = s.camera;
  f.takeLightingFrom(s);
  gpu.renderer->setGBufferPath(GBufferPath::Compute);
  const render::Frame frame = gpu.renderer->render(gpu.scene, f);
  gpu.renderer->setGBufferPath(GBufferPath::Raster);
  CHECK(hasPass(frame, "gbuffer"));
  CHECK_FALSE(hasPass(frame, "visibility"));
  // Auto on a CPU device (lavapipe) is raster too, even for a scene that qualifies.
  gpu.setScene(scene::makeBuiltinScene(8));
  if (gpu.context->info.type == "cpu") {
    gpu.renderer->setGBufferPath(GBufferPath::Auto);
    const render::Frame autoFrame = gpu.renderer->render(gpu.scene, f);
    gpu.renderer->setGBufferPath(GBufferPath::Raster);
    CHECK(hasPass(autoFrame, "gbuffer"));
  }
  CHECK(gpu.context->validationMessages.load() == 0);
}
