#version 450
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"

// The shadow pass: depth only, from the light (render/shadows.cpp). No fragment shader.
layout(location = 0) in vec3 inPosition;

layout(push_constant) uniform ShadowBlock {
  ShadowPush shadow;
};

// One draw per instance, as in the G-buffer pass: firstInstance carries the instance index.
void main() {
  gl_Position = shadow.viewProjection * (instances[gl_InstanceIndex].model * vec4(inPosition, 1.0));
}
