#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// Experiment: the subgroup walk, each pixel queueing the lights reaching it, shaded together.
#define MYRIAD_CLUSTER_SUBGROUP_WALK
#define MYRIAD_CLUSTER_PREPARED
#define MYRIAD_CLUSTER_QUEUE
#include "light_clustered.glsl"
