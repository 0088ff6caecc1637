#version 450
// The label pass (render/passes.cpp recordLabelPass): gbuffer.vert's surfaces again, depth-tested
// EQUAL against the G-buffer's depth, so each pixel takes the labels of the surface the G-buffer
// kept there (an alpha-tested surface's cut-out fragments never wrote that depth).

layout(location = 3) flat in uint inMaterial;
layout(location = 6) flat in uvec2 inLabels;  // object, semantic class

layout(location = 0) out uvec4 outLabel;  // object, semantic, material, 1: a surface

void main() { outLabel = uvec4(inLabels.x, inLabels.y, inMaterial, 1u); }
