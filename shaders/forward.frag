#version 450
#extension GL_GOOGLE_include_directive : require
// Alpha-blended surfaces, every light tested (shaders/forward.glsl).
#include "forward.glsl"
