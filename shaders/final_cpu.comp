#version 450
#extension GL_GOOGLE_include_directive : require
// final_pass.glsl writing the 8-bit output image on CPU devices (DeviceInfo::isCpu): edge pixels
// listed with one global atomic each instead of a group count and two workgroup barriers.
#define MYRIAD_FINAL_CPU 1
#include "final_pass.glsl"
