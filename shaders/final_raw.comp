#version 450
#extension GL_GOOGLE_include_directive : require
// final_pass.glsl writing raw values (RGBA32F output, FrameSettings::raw).
#define MYRIAD_RAW_OUTPUT 1
#include "final_pass.glsl"
