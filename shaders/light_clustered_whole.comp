#version 450
#extension GL_GOOGLE_include_directive : require
// Clustered step 5, each pixel walking its cluster's whole list (light_clustered_pixel.glsl says
// when that is the faster pass).
#define MYRIAD_SHADE_WHOLE_LISTS 1
#include "light_clustered_pixel.glsl"
