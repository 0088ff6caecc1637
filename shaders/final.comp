#version 450
#extension GL_GOOGLE_include_directive : require
// final_pass.glsl writing the 8-bit output image (RGBA8_UNORM).
#include "final_pass.glsl"
