// What the anti-aliasing tests measure with (antialias_modes_tests.cpp: the stills' taa and ssaa;
// temporal_aa_tests.cpp: a stream's taa): the boxes scene, the 4x supersampled reference
// (box-downsampled in linear light), its edge pixels and the edge error against it.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "render/frame.h"
#include "scene/primitives.h"
#include "scene/scene.h"

namespace myriad::test::aa {

inline constexpr uint32_t kWidth = 160;
inline constexpr uint32_t kHeight = 120;
inline constexpr uint32_t kReferenceScale = 4;

// Two dark boxes on a bright floor, their top faces' edges at 10 and 37 degrees off the rows seen
// from straight above; the first box `shift` metres along x.
inline scene::Scene boxesScene(float shift = 0.0f) {
  scene::Scene s;
  s.meshes.push_back(scene::makePlane(4.0f));
  s.meshes.push_back(scene::makeCube());
  s.materials.push_back({"floor", glm::vec3(0.8f), 0.0f, 1.0f});
  s.materials.push_back({"box", glm::vec3(0.02f), 0.0f, 1.0f});
  s.materials.push_back({"red box", glm::vec3(0.6f, 0.05f, 0.02f), 0.0f, 1.0f});
  s.instances.push_back({0, 0, glm::scale(glm::mat4(1.0f), glm::vec3(40.0f, 1.0f, 40.0f))});
  struct Box {
    glm::vec3 at;
    float degrees;
    float side;
    uint32_t material;
  };
  for (const Box& b : {Box{{-1.6f + shift, 0.5f, 0.2f}, 10.0f, 2.2f, 1},
                       Box{{1.9f, 0.5f, -0.3f}, 37.0f, 1.8f, 2}}) {
    glm::mat4 m = glm::translate(glm::mat4(1.0f), b.at);
    m = glm::rotate(m, glm::radians(b.degrees), glm::vec3(0.0f, 1.0f, 0.0f));
    s.instances.push_back({1, b.material, glm::scale(m, glm::vec3(b.side, 1.0f, b.side))});
  }
  s.sun.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  s.sun.intensity = 2.0f;
  s.ambient = glm::vec3(0.05f);
  return s;
}

inline float toLinear(float code) {
  const float c = code / 255.0f;
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

inline float toCode(float linear) {
  const float v = std::clamp(linear, 0.0f, 1.0f);
  return 255.0f * (v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f);
}

// The 4x image box-downsampled in linear light: RGB sRGB codes (floats) at kWidth x kHeight.
inline std::vector<float> downsampled(const render::Frame& big) {
  REQUIRE(big.width == kWidth * kReferenceScale);
  std::vector<float> out(size_t(kWidth) * kHeight * 3);
  const auto px = big.pixels();
  for (uint32_t y = 0; y < kHeight; ++y) {
    for (uint32_t x = 0; x < kWidth; ++x) {
      for (int c = 0; c < 3; ++c) {
        float sum = 0.0f;
        for (uint32_t dy = 0; dy < kReferenceScale; ++dy) {
          for (uint32_t dx = 0; dx < kReferenceScale; ++dx) {
            const size_t i = (size_t(y * kReferenceScale + dy) * big.width + x * kReferenceScale + dx) * 4;
            sum += toLinear(px[i + c]);
          }
        }
        out[(size_t(y) * kWidth + x) * 3 + c] = toCode(sum / float(kReferenceScale * kReferenceScale));
      }
    }
  }
  return out;
}

inline std::vector<bool> edgePixels(const std::vector<float>& reference) {
  std::vector<bool> edge(size_t(kWidth) * kHeight, false);
  auto differs = [&](size_t a, size_t b) {
    for (int c = 0; c < 3; ++c) {
      if (std::abs(reference[a * 3 + c] - reference[b * 3 + c]) > 16.0f) return true;
    }
    return false;
  };
  for (uint32_t y = 0; y < kHeight; ++y) {
    for (uint32_t x = 0; x < kWidth; ++x) {
      const size_t i = size_t(y) * kWidth + x;
      if (x + 1 < kWidth && differs(i, i + 1)) edge[i] = edge[i + 1] = true;
      if (y + 1 < kHeight && differs(i, i + kWidth)) edge[i] = edge[i + kWidth] = true;
    }
  }
  return edge;
}

// Pixels within `radius` of an edge pixel.
inline std::vector<bool> nearEdges(const std::vector<bool>& edges, int radius) {
  std::vector<bool> near(edges.size(), false);
  for (int y = 0; y < int(kHeight); ++y) {
    for (int x = 0; x < int(kWidth); ++x) {
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx >= 0 && ny >= 0 && nx < int(kWidth) && ny < int(kHeight) &&
              edges[size_t(ny) * kWidth + nx]) {
            near[size_t(y) * kWidth + x] = true;
          }
        }
      }
    }
  }
  return near;
}

inline double edgeError(const render::Frame& frame, const std::vector<float>& reference,
                 const std::vector<bool>& edges) {
  REQUIRE(frame.width == kWidth);
  REQUIRE(frame.height == kHeight);
  const auto px = frame.pixels();
  REQUIRE(px.size() == size_t(kWidth) * kHeight * 4);
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    if (!edges[i]) continue;
    for (int c = 0; c < 3; ++c) sum += std::abs(double(px[i * 4 + c]) - reference[i * 3 + c]);
    count += 3;
  }
  return sum / double(count);
}

inline bool sameBits(std::span<const float> a, std::span<const float> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size_bytes()) == 0;
}

inline std::span<const float> extraOf(const render::Frame& f, render::Target t) {
  for (const render::Frame::TargetValues& v : f.extras) {
    if (v.target == t) return v.data;
  }
  return {};
}

inline std::vector<uint8_t> bytesOf(const render::Frame& f) { return {f.pixels().begin(), f.pixels().end()}; }

}  // namespace myriad::test::aa
