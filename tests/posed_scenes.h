// Skinned and morphed scenes built in code (no files) for the GPU pre-pass's tests
// (skinning_tests.cpp, motion_tests.cpp), and the same deformation done on the CPU: a copy of a
// mesh posed as shaders/skinning.comp poses it, to be rendered unposed and compared.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::test {

// A square tube along +x from 0 to `length` (half-width `half`), `rings` rings of 8 vertices
// (two per side, flat normals, tangents along +x), its two open ends closed by nothing (the
// material is double-sided). uv: u along the length, v around. Skinned by `joints` joints spaced
// evenly along it (joint k's bind place x = k * length / joints), each vertex weighing the two
// joints around it.
inline scene::Mesh makeBar(float length, float half, uint32_t rings, uint32_t joints) {
  scene::Mesh m;
  m.name = "bar";
  const glm::vec3 corners[4] = {{0, -half, -half}, {0, half, -half}, {0, half, half}, {0, -half, half}};
  const glm::vec3 normals[4] = {{0, 0, -1}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}};
  const float segment = length / float(joints);
  for (uint32_t r = 0; r < rings; ++r) {
    const float x = length * float(r) / float(rings - 1);
    for (uint32_t side = 0; side < 4; ++side) {
      for (uint32_t c = 0; c < 2; ++c) {
        scene::Vertex v;
        v.position = corners[(side + c) % 4] + glm::vec3(x, 0, 0);
        v.normal = normals[side];
        v.uv = glm::vec2(x / length, (float(side) + float(c)) / 4.0f);
        v.tangent = glm::vec4(1, 0, 0, 1);
        v.color = glm::vec4(1.0f);
        m.vertices.push_back(v);
        // The joints around x (bind places at k * segment), weighed linearly between them.
        const float t = x / segment - 0.5f;
        const uint32_t k0 = uint32_t(std::clamp(std::floor(t), 0.0f, float(joints - 1)));
        const uint32_t k1 = std::min(k0 + 1, joints - 1);
        const float f = t <= 0.0f ? 0.0f : std::clamp(t - std::floor(t), 0.0f, 1.0f);
        m.joints.push_back(glm::uvec4(k0, k1, 0, 0));
        m.weights.push_back(k0 == k1 ? glm::vec4(1, 0, 0, 0) : glm::vec4(1.0f - f, f, 0, 0));
      }
    }
  }
  for (uint32_t r = 0; r + 1 < rings; ++r) {
    for (uint32_t side = 0; side < 4; ++side) {
      const uint32_t a = r * 8 + side * 2, b = a + 1, c = a + 8, d = b + 8;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  }
  return m;
}

// The skin of makeBar's joints: nodes in a chain along +x, inverse binds at their rest places.
inline void addBarSkin(scene::Scene& s, float length, uint32_t joints) {
  scene::Skin skin;
  const uint32_t first = uint32_t(s.nodes.size());
  for (uint32_t k = 0; k < joints; ++k) {
    scene::Node n;
    n.parent = k == 0 ? -1 : int32_t(first + k - 1);
    n.translation = glm::vec3(k == 0 ? 0.0f : length / float(joints), 0, 0);
    s.nodes.push_back(n);
    skin.joints.push_back(first + k);
    skin.inverseBind.push_back(glm::translate(glm::mat4(1.0f), glm::vec3(-float(k) * length / float(joints), 0, 0)));
  }
  s.skins.push_back(skin);
}

// Skinning matrices of makeBar's joints, each joint bent by angles[k] (radians) about `axis`
// relative to its parent: world_k * inverseBind_k.
inline std::vector<glm::mat4> barPose(float length, const std::vector<float>& angles,
                                      glm::vec3 axis = glm::vec3(0, 0, 1)) {
  const uint32_t joints = uint32_t(angles.size());
  std::vector<glm::mat4> out;
  glm::mat4 world(1.0f);
  for (uint32_t k = 0; k < joints; ++k) {
    if (k > 0) world = world * glm::translate(glm::mat4(1.0f), glm::vec3(length / float(joints), 0, 0));
    world = world * glm::rotate(glm::mat4(1.0f), angles[k], axis);
    out.push_back(world * glm::translate(glm::mat4(1.0f), glm::vec3(-float(k) * length / float(joints), 0, 0)));
  }
  return out;
}

// A grid in the xz plane (size x size, `cells` across), facing +y, with two morph targets: a
// bump raising the middle (positions and normals) and a twist of the tangents.
inline scene::Mesh makeMorphGrid(float size, uint32_t cells) {
  scene::Mesh m;
  m.name = "grid";
  scene::MorphTarget bump{"bump", {}, {}, {}}, tilt{"tilt", {}, {}, {}};
  for (uint32_t j = 0; j <= cells; ++j) {
    for (uint32_t i = 0; i <= cells; ++i) {
      const float u = float(i) / float(cells), v = float(j) / float(cells);
      scene::Vertex vx;
      vx.position = glm::vec3((u - 0.5f) * size, 0.0f, (v - 0.5f) * size);
      vx.normal = glm::vec3(0, 1, 0);
      vx.uv = glm::vec2(u, v);
      vx.tangent = glm::vec4(1, 0, 0, 1);
      m.vertices.push_back(vx);
      const float dx = u - 0.5f, dz = v - 0.5f;
      const float h = std::exp(-(dx * dx + dz * dz) * 12.0f);
      bump.positions.push_back(glm::vec3(0.0f, 0.6f * size * h, 0.0f));
      // The bump's slope: the normal leans away from the middle.
      bump.normals.push_back(glm::vec3(dx * h * 8.0f, 0.0f, dz * h * 8.0f));
      tilt.positions.push_back(glm::vec3(0.0f, 0.15f * size * dx, 0.0f));
      tilt.tangents.push_back(glm::vec3(0.0f, 0.3f * dx, 0.2f));
    }
  }
  for (uint32_t j = 0; j < cells; ++j) {
    for (uint32_t i = 0; i < cells; ++i) {
      const uint32_t a = j * (cells + 1) + i, b = a + 1, c = a + cells + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  }
  m.morphTargets = {bump, tilt};
  m.morphWeights = {0.0f, 0.0f};
  return m;
}

// `mesh` deformed on the CPU as the pre-pass deforms it (morph, then skin, normal and tangent
// by the blended matrix and normalised): its vertices only, no skin or targets left.
inline scene::Mesh posedOnCpu(const scene::Mesh& mesh, const std::vector<glm::mat4>& joints,
                              const std::vector<float>& weights) {
  scene::Mesh out = mesh;
  out.joints.clear();
  out.weights.clear();
  out.morphTargets.clear();
  out.morphWeights.clear();
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    glm::vec3 p = mesh.vertices[v].position, n = mesh.vertices[v].normal;
    glm::vec3 t = glm::vec3(mesh.vertices[v].tangent);
    for (size_t k = 0; k < mesh.morphTargets.size() && k < weights.size(); ++k) {
      const scene::MorphTarget& target = mesh.morphTargets[k];
      if (weights[k] == 0.0f) continue;
      if (!target.positions.empty()) p += weights[k] * target.positions[v];
      if (!target.normals.empty()) n += weights[k] * target.normals[v];
      if (!target.tangents.empty()) t += weights[k] * target.tangents[v];
    }
    if (mesh.skinned() && !joints.empty()) {
      glm::mat4 blend(0.0f);
      float sum = 0.0f;
      for (int i = 0; i < 4; ++i) {
        const float w = mesh.weights[v][i];
        if (w == 0.0f || mesh.joints[v][i] >= joints.size()) continue;
        blend += w * joints[mesh.joints[v][i]];
        sum += w;
      }
      if (sum > 0.0f) {
        blend /= sum;
        p = glm::vec3(blend * glm::vec4(p, 1.0f));
        n = glm::mat3(blend) * n;
        t = glm::mat3(blend) * t;
      }
    }
    out.vertices[v].position = p;
    out.vertices[v].normal = glm::length(n) > 0.0f ? glm::normalize(n) : n;
    out.vertices[v].tangent = glm::vec4(glm::length(t) > 0.0f ? glm::normalize(t) : t,
                                        mesh.vertices[v].tangent.w);
  }
  return out;
}

}  // namespace myriad::test
