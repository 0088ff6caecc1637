#version 450
#extension GL_GOOGLE_include_directive : require
// The motion pass (render/motion.cpp): the G-buffer's surfaces again, depth-tested EQUAL against
// its depth (gl_Position exactly as gbuffer.vert computes it), each vertex also placed where it
// was at the previous time: by the instance's previous placement and, for a skinned or morphed
// instance, its previous deformed position (the pre-pass wrote it), seen by the previous camera.
#include "frame.glsl"

layout(location = 0) in vec3 inPosition;

layout(std430, set = MYRIAD_SET_MOTION, binding = MYRIAD_MOTION_BINDING_INSTANCES) readonly buffer PreviousInstanceBlock {
  GpuInstance previousInstances[];
};
layout(std430, set = MYRIAD_SET_MOTION, binding = MYRIAD_MOTION_BINDING_VERTICES) readonly buffer VertexRecordBlock {
  uvec4 vertexRecords[];
};
layout(std430, set = MYRIAD_SET_MOTION, binding = MYRIAD_MOTION_BINDING_PREVIOUS) readonly buffer PreviousBlock {
  vec4 previousPositions[];
};
layout(push_constant) uniform MotionBlock {
  MotionPush motion;
};

layout(location = 0) out vec4 outPreviousClip;

void main() {
  GpuInstance instance = instances[gl_InstanceIndex];
  vec4 world = instance.model * vec4(inPosition, 1.0);
  gl_Position = frame.viewProjection * world;

  vec3 previous = inPosition;
  if (motion.flags.x != 0u) {
    // gl_VertexIndex counts from the buffer's start (it includes the draw's vertexOffset).
    const uvec4 record = vertexRecords[gl_InstanceIndex];
    if (record.x != MYRIAD_SKIN_NONE) {
      previous = previousPositions[record.x + uint(gl_VertexIndex) - record.y].xyz;
    }
  }
  outPreviousClip = motion.previousViewProjection *
                    (previousInstances[gl_InstanceIndex].model * vec4(previous, 1.0));
}
