#version 450
#extension GL_GOOGLE_include_directive : require
// views_pass.glsl writing raw values (RGBA32F output, FrameSettings::raw).
#define MYRIAD_RAW_OUTPUT 1
#include "views_pass.glsl"
