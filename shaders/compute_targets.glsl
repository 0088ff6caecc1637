// What the compute lighting passes write and the culling data they share.
#ifndef MYRIAD_COMPUTE_TARGETS_GLSL
#define MYRIAD_COMPUTE_TARGETS_GLSL

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_HDR_STORAGE, rgba16f) uniform writeonly image2D hdrOut;
layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_LIGHT_COUNT_STORAGE, r32f) uniform writeonly image2D lightCountOut;

layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_RANGES) buffer ClusterRangeBlock {
  uvec2 clusterRanges[];  // first index into clusterLights, number of lights
};
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_LIGHTS) buffer ClusterLightBlock {
  uint clusterLights[];
};
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CULLING_STATS) buffer StatsBlock {
  CullingStats stats;
};
#include "cluster_cursors.glsl"
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_LARGE_LIGHTS) buffer LargeLightBlock {
  LargeLightQueue largeQueue;
  uint largeLights[];
};
// The pairs the counting pass recorded (cluster_assign_binned.comp; sized by the technique, a
// single word where nothing is recorded).
layout(std430, set = MYRIAD_SET_CULLING, binding = MYRIAD_BINDING_CLUSTER_PAIRS) buffer PairBlock {
  uint pairWords[];
};

#endif
