#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
// Clustered shading walked per subgroup (light_clustered.glsl); for devices with subgroup vote,
// arithmetic, ballot and shuffle in compute shaders.
#include "light_clustered.glsl"
