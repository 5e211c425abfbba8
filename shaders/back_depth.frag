#version 330 core
// The second layer of a depth image: the window depth of the nearest back face, drawn with front
// faces culled into the G channel of the depth atlas (the R channel, the visible surface, is
// masked off). Between the two lies the first solid run of the object along each eye ray, which
// is what lets a reflected ray that passes behind a silhouette tell "through the object's hidden
// side" (a hit) from "behind it, through empty space" (no hit).
layout(location = 1) out vec2 out_depth;

void main() {
    out_depth = vec2(gl_FragCoord.z);
}
