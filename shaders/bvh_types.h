// The BVH of the scene's triangles (render/bvh.h), shared by C++ and GLSL like shared_types.h:
// binding indices, constants and GPU struct layouts (vec4/uvec4 members only; the C++ side
// checks sizes in render/bvh.cpp). Its own header: only the BVH's passes and the shadow rays
// read it.
#ifndef MYRIAD_BVH_TYPES_H
#define MYRIAD_BVH_TYPES_H

#include "shared_types.h"

#ifdef __cplusplus
namespace myriad::gpu_types {
#endif

// The build passes' set (render/bvh.cpp; the only set of their layout). The trace set (what the
// shadow rays read) holds its first three bindings at the same numbers.
#define MYRIAD_BVH_BINDING_TRIANGLES 0  // BvhTriangle[]: world space, in the draw table's order
#define MYRIAD_BVH_BINDING_NODES 1      // BvhNode[2n - 1]: n - 1 internal nodes (0 the root), n leaves
#define MYRIAD_BVH_BINDING_HEADER 2     // BvhHeader
#define MYRIAD_BVH_BINDING_KEYS 3       // uint[2n]: Morton codes, two halves the radix sort ping-pongs
#define MYRIAD_BVH_BINDING_VALUES 4     // uint[2n]: triangle indices, sorted along with the keys
#define MYRIAD_BVH_BINDING_HISTOGRAM 5  // uint[MYRIAD_BVH_SORT_BINS x sort groups]: digit counts
#define MYRIAD_BVH_BINDING_PARENTS 6    // uint[2n - 1] each node's parent, then uint[n - 1] arrivals
#define MYRIAD_BVH_BINDING_VERTICES 7   // the scene's vertices (scene::Vertex, MYRIAD_VERTEX_FLOATS)
#define MYRIAD_BVH_BINDING_INDICES 8    // the scene's indices
#define MYRIAD_BVH_BINDING_DRAWS 9      // uvec4[]: [draws, triangles], then per draw [first triangle,
                                        // first index, vertex offset, instance] (visibility.glsl's)
#define MYRIAD_BVH_BINDING_INSTANCES 10 // GpuInstance[]
#define MYRIAD_BVH_BINDING_MATERIALS 11 // GpuMaterial[]
#define MYRIAD_BVH_BINDING_RAYS 12      // BvhRay[] (bvh_query.comp: the tests' rays)
#define MYRIAD_BVH_BINDING_HITS 13      // uint[] per ray: 1 occluded, 0 not
#define MYRIAD_BVH_BINDING_BOXES 14     // uint[8 (n - 1)]: the bounds pass's internal boxes as
                                        // order-preserving bits, minima (4 a node) then maxima
#define MYRIAD_BVH_BINDINGS 15
#define MYRIAD_BVH_TRACE_BINDINGS 3     // the trace set: triangles, nodes, header

#define MYRIAD_BVH_GROUP 256       // invocations per workgroup of every build pass
#define MYRIAD_BVH_SORT_BITS 8     // radix sort digit: four passes over 32-bit keys
#define MYRIAD_BVH_SORT_BINS 256
#define MYRIAD_BVH_SORT_ROUNDS 8   // a sort workgroup takes GROUP x ROUNDS keys, GROUP a round
#define MYRIAD_BVH_SCAN_GROUP 256  // the histogram's scan: one workgroup, 4 counts an invocation
#define MYRIAD_BVH_STACK 64        // traversal stack: 30-bit codes + 32-bit index tie-break
#define MYRIAD_BVH_NONE 0xFFFFFFFFu
#define MYRIAD_BVH_LEAF 0xFFFFFFFFu  // BvhNode.hi.w of a leaf (lo.w is its triangle)
#define MYRIAD_BVH_TRIANGLE_CLEAR 1u // BvhTriangle.v0.w bit: casts no shadow (alpha below cutoff)

// The build passes' push constants (MYRIAD_BVH_PUSH_BYTES).
MYRIAD_STRUCT(BvhPush) {
  vec4 boundsMin;  // the box the Morton codes quantise (the scene's bounds, padded)
  vec4 boundsMax;
  uvec4 params;    // x triangles, y the sort pass's shift (bits), z which key half it reads (0/1),
                   // w sort groups
};

// A triangle in world space: xyz the vertices; v0.w MYRIAD_BVH_TRIANGLE_* bits (float bits).
MYRIAD_STRUCT(BvhTriangle) {
  vec4 v0;
  vec4 v1;
  vec4 v2;
};

// A node: its box, and in w its children (internal: left, right as node indices; a leaf: its
// triangle index and MYRIAD_BVH_LEAF), as float bits.
MYRIAD_STRUCT(BvhNode) {
  vec4 lo;
  vec4 hi;
};

MYRIAD_STRUCT(BvhHeader) {
  uvec4 counts;  // x triangles (n), y internal nodes (n - 1; 0 for n <= 1), zw unused
};

// A test ray (bvh_query.comp): occluded if a triangle crosses it at tMin < t < tMax.
MYRIAD_STRUCT(BvhRay) {
  vec4 originTMin;
  vec4 directionTMax;
};

#ifdef __cplusplus
}  // namespace myriad::gpu_types
#endif
#endif
