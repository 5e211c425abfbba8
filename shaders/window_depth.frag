#version 330 core
#include "lib/alpha_mask.glsl"
// The window depth alone, into the float layers of a depth image: the nearest back face (drawn
// with front faces culled, into the G channel of a depth atlas: output 1), and both layers of a
// shadow map (output 0; passes/shadows.py). Between the visible surface and the nearest back
// face behind it lies the first solid run of the object along each eye ray, which is what lets
// a ray that passes behind a silhouette tell "through the object's hidden side" (a hit) from
// "behind it, through empty space" (no hit).
#ifndef OUTPUT_LOCATION
#define OUTPUT_LOCATION 1
#endif
layout(location = OUTPUT_LOCATION) out vec2 out_depth;

void main() {
    discard_masked();
    out_depth = vec2(gl_FragCoord.z);
}
