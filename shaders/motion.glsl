// The motion pass's fragments (motion.frag: raw values; motion_view.frag: a false-colour
// picture): the screen-space motion of the surface at this pixel from the previous time to this
// frame's, in pixels (x right, y down): its pixel now minus its pixel then.
#include "shared_types.h"

layout(location = 0) in vec4 inPreviousClip;

layout(push_constant) uniform MotionBlock {
  MotionPush motion;
};

// `viewport`: the frame's width and height in pixels.
vec2 motionPixels(vec2 viewport) {
  // A point behind the previous camera has no pixel then: no motion is claimed.
  if (inPreviousClip.w <= 0.0) return vec2(0.0);
  const vec2 previousPixel = (inPreviousClip.xy / inPreviousClip.w * 0.5 + 0.5) * viewport;
  return gl_FragCoord.xy - previousPixel;
}
