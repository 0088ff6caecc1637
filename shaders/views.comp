#version 450
#extension GL_GOOGLE_include_directive : require
// views_pass.glsl writing the 8-bit output image (RGBA8_UNORM).
#include "views_pass.glsl"
