#version 450
#extension GL_GOOGLE_include_directive : require
// The motion target as a picture (render/motion.h): the direction as hue (right red, down
// yellow-green, left cyan, up violet), the length as saturation, full at 1/32 of the frame's larger
// side; white where nothing moved, black where no surface is (the clear colour).
#include "motion.glsl"

layout(set = MYRIAD_SET_SCENE, binding = MYRIAD_BINDING_FRAME) uniform FrameBlock {
  FrameUniforms frame;
};

layout(location = 0) out vec4 outColor;

void main() {
  const vec2 m = motionPixels(frame.viewport.xy);
  const float fullAt = max(frame.viewport.x, frame.viewport.y) / 32.0;
  const float hue = fract(atan(m.y, m.x) / 6.28318530718 + 1.0);
  const vec3 rgb = clamp(abs(fract(hue + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0);
  outColor = vec4(mix(vec3(1.0), rgb, clamp(length(m) / fullAt, 0.0, 1.0)), 1.0);
}
