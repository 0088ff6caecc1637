#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// Experiment: the subgroup walk over the clusters' whole lists, without the tile's narrowing.
#define MYRIAD_CLUSTER_SUBGROUP_WALK
#define MYRIAD_CLUSTER_DIRECT
#include "light_clustered.glsl"
