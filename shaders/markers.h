// Light markers (shaders/marker_splat.comp, resolved in final.comp; render/passes.cpp): shared by
// GLSL and C++ like shared_types.h.
#ifndef MYRIAD_MARKERS_H
#define MYRIAD_MARKERS_H

// The per-pixel marker keys, R32_UINT storage image (GENERAL) at set 1 MYRIAD_BINDING_MARKER_KEYS
// (shared_types.h). A key is (weight << 24) | (light index + 1), weight the marker's falloff at the pixel in 1..255;
// 0 = no marker. imageAtomicMax keeps the strongest marker at each pixel, ties to the higher
// index, so the picture does not depend on the order the threads ran in.
#define MYRIAD_MARKER_INDEX_BITS 24u

// Markers' size and share (markers.glsl; the service's light picking, render/marker_pick.h):
// markers may cover at most COVERAGE of the picture (every drawn marker in view, none hidden);
// the largest radius in pixels (few lights); below MIN_RADIUS a marker is the one pixel that
// holds the light's centre.
#define MYRIAD_MARKER_COVERAGE 0.08
#define MYRIAD_MARKER_MAX_RADIUS 3.5
#define MYRIAD_MARKER_MIN_RADIUS 1.0

#endif
