#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 5, each pixel on its own after its tile narrowed the lists (light_clustered_pixel.glsl).
#include "light_clustered_pixel.glsl"
