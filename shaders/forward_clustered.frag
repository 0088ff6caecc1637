#version 450
#extension GL_GOOGLE_include_directive : require
// Alpha-blended surfaces, lit from the clustered lists (shaders/forward.glsl).
#define MYRIAD_FORWARD_CLUSTERED
#include "forward.glsl"
