#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
// Experiment: the subgroup walk with MYRIAD_BALLOT_FROM 4294967294.
#define MYRIAD_BALLOT_FROM 4294967294u
#include "light_clustered.glsl"
