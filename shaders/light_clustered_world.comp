#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered shading, each pixel walking its tile's narrowed list (light_clustered.glsl).
#include "light_clustered.glsl"
