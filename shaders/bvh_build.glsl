// The BVH's build passes (render/bvh.cpp): their one set and push constants. A linear BVH
// (Karras, HPG 2012): triangles gathered in world space, Morton codes of their centroids sorted by
// a radix sort, the hierarchy read off the sorted codes, boxes filled bottom-up.
#ifndef MYRIAD_BVH_BUILD_GLSL
#define MYRIAD_BVH_BUILD_GLSL

#include "bvh_types.h"

layout(push_constant) uniform BvhPushBlock {
  BvhPush push;
};

layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_TRIANGLES) buffer TriangleBlock {
  BvhTriangle triangles[];
};
// Coherent: the bounds pass reads boxes other invocations wrote in the same dispatch.
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_NODES) coherent buffer NodeBlock {
  BvhNode nodes[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_HEADER) buffer HeaderBlock {
  BvhHeader header;
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_KEYS) buffer KeyBlock {
  uint keys[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_VALUES) buffer ValueBlock {
  uint values[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_HISTOGRAM) buffer HistogramBlock {
  uint histogram[];
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_PARENTS) coherent buffer ParentBlock {
  uint parents[];  // 2n - 1 parents, then n - 1 arrival counters
};
layout(std430, set = 0, binding = MYRIAD_BVH_BINDING_BOXES) coherent buffer BoxBlock {
  uint boxBits[];  // per internal node 4 minima, then (from 4 (n - 1)) 4 maxima
};

uint triangleCount() { return push.params.x; }

#endif
