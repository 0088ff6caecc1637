#version 450
#extension GL_GOOGLE_include_directive : require
// Raw motion (render/motion.h): dx, dy in pixels, 1 where a surface is, 0.
#include "motion.glsl"

layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};

layout(location = 0) out vec4 outMotion;

void main() { outMotion = vec4(motionPixels(frame.viewport.xy), 1.0, 0.0); }
