// What the two marker passes share: how big markers are and how many are drawn, from the light
// count and the frame size alone (so every technique and both passes agree).
#ifndef MYRIAD_MARKERS_GLSL
#define MYRIAD_MARKERS_GLSL

#include "markers.h"

layout(set = MYRIAD_SET_TARGETS, binding = MYRIAD_BINDING_MARKER_KEYS, r32ui) uniform uimage2D markerKeys;

// markers.h says why (shared with the service's light picking, render/marker_pick.h).
const float kMarkerCoverage = MYRIAD_MARKER_COVERAGE;
const float kMarkerMaxRadius = MYRIAD_MARKER_MAX_RADIUS;
const float kMarkerMinRadius = MYRIAD_MARKER_MIN_RADIUS;

float markerBudget() { return kMarkerCoverage * frame.viewport.x * frame.viewport.y; }

// Radius in pixels: the budget shared among the lights, bounded to [0, kMarkerMaxRadius].
float markerRadius() {
  float n = max(float(frame.flags.y), 1.0);
  return min(sqrt(markerBudget() / (3.14159265 * n)), kMarkerMaxRadius);
}

// Share of the lights that get a marker: all while one-pixel markers fit the budget, then fewer.
float markerKeep() {
  return min(1.0, markerBudget() / max(float(frame.flags.y), 1.0));
}

// Opacity of a marker's centre: full for a few lights, fading to 0.6 as they shrink to a pixel.
float markerOpacity() {
  return 0.6 + 0.4 * clamp((markerRadius() - kMarkerMinRadius) / (kMarkerMaxRadius - kMarkerMinRadius), 0.0, 1.0);
}

#endif
