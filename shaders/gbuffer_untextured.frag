#version 450
#extension GL_GOOGLE_include_directive : require
// Opaque materials without textures: see gbuffer.glsl.
#define MYRIAD_MATERIAL_UNTEXTURED
#include "gbuffer.glsl"
