#version 450
#extension GL_GOOGLE_include_directive : require
// Opaque materials: see gbuffer.glsl.
#include "gbuffer.glsl"
