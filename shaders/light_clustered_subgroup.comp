#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// Clustered shading, each subgroup walking its tile's narrowed list together
// (light_clustered.glsl); for devices with subgroup ballot and arithmetic in compute shaders.
#define MYRIAD_CLUSTER_SUBGROUP_WALK
#include "light_clustered.glsl"
