#version 450
#extension GL_GOOGLE_include_directive : require
// final_pass.glsl writing the 8-bit output image on CPU devices (DeviceInfo::isCpu): one pixel
// each, no shared memory; with anti-aliasing antialias_edges.comp then tests the edges.
#define MYRIAD_FINAL_CPU 1
#include "final_pass.glsl"
