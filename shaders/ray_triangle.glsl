// The shadow rays' triangle test, written once in the common subset of GLSL 4.50 and C++20/GLM
// (the rules of shading.glsl): the GPU's traversal (bvh_trace.glsl) and the tests' brute-force
// CPU twin (render/bvh.h rayHitsTriangle) run this same code.
#ifndef MYRIAD_RAY_TRIANGLE_GLSL
#define MYRIAD_RAY_TRIANGLE_GLSL

// Moller-Trumbore (1997): whether the ray origin + t dir crosses triangle (a, b, c) at
// tMin < t < tMax, either face. Edges and vertices count as inside (u, v >= 0, u + v <= 1), so a
// ray through a shared edge hits one of the two triangles at least: watertight enough for shadow
// rays, whose answer only differs from an exact one within rounding of an edge. A triangle seen
// edge-on (determinant 0) is missed.
bool rayHitsTriangle(vec3 origin, vec3 dir, vec3 a, vec3 b, vec3 c, float tMin, float tMax) {
  vec3 e1 = b - a;
  vec3 e2 = c - a;
  vec3 p = cross(dir, e2);
  float det = dot(e1, p);
  if (det == 0.0f) {
    return false;
  }
  float inverseDet = 1.0f / det;
  vec3 s = origin - a;
  float u = dot(s, p) * inverseDet;
  if (u < 0.0f || u > 1.0f) {
    return false;
  }
  vec3 q = cross(s, e1);
  float v = dot(dir, q) * inverseDet;
  if (v < 0.0f || u + v > 1.0f) {
    return false;
  }
  float t = dot(e2, q) * inverseDet;
  return t > tMin && t < tMax;
}

#endif
