#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// Experiment: the subgroup walk with the BRDF's per-pixel terms worked out once per pixel.
#define MYRIAD_CLUSTER_SUBGROUP_WALK
#define MYRIAD_CLUSTER_PREPARED
#include "light_clustered.glsl"
