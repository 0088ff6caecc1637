#version 450
#extension GL_GOOGLE_include_directive : require
// alphaMode MASK materials: see gbuffer.glsl.
#define MYRIAD_GBUFFER_ALPHA_TEST
#include "gbuffer.glsl"
