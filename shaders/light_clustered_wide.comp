#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// Experiment: the prepared subgroup walk with 32x32-pixel tiles (1,024 invocations).
#define MYRIAD_SHADE_TILE 32
#define MYRIAD_SHADE_TILE_LIGHTS 4096
#define MYRIAD_CLUSTER_SUBGROUP_WALK
#define MYRIAD_CLUSTER_PREPARED
#include "light_clustered.glsl"
