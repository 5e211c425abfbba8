#version 330 core
// A glass object's interior image (passes/glass.py): each sample's outward unit normal and
// window depth. Drawn twice from one camera, front faces into one texture and back faces (front
// ones culled) into the other: between the two lies the glass along each eye ray.
#include "lib/common.glsl"

in vec3 v_world_normal;

out vec4 out_surface;

void main() {
    // A degenerate normal (zero) would be NaN; any unit vector is as good for a zero-area fold.
    out_surface = vec4(safe_normalize(v_world_normal, vec3(0.0, 1.0, 0.0)), gl_FragCoord.z);
}
