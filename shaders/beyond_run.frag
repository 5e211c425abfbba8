#version 330 core
#include "lib/alpha_mask.glsl"
// The hybrid method's depth images: where the space behind an object's first solid run stops being
// known empty. Drawn after the back layer, with back faces culled, against a fresh depth buffer:
// the nearest front face behind the first run (depth peeling, one layer) is where a second solid
// run begins. Between the run and it nothing lies along the eye ray; where no front face lies
// behind, nothing does at all (the cleared BACKGROUND_DEPTH).
#include "lib/solid_run.glsl"

uniform sampler2D u_impostor_depth;  // the atlas's layers (visible surface, back face)

layout(location = 0) out float out_beyond;

void main() {
    discard_masked();
    vec2 run = solid_run(texelFetch(u_impostor_depth, ivec2(gl_FragCoord.xy), 0).rg);
    // Faces meet the run's back at a silhouette at its own depth: a front face counts only
    // beyond the contact tolerance (a second run nearer than that is taken for none).
    if (run.x >= BACKGROUND_DEPTH || gl_FragCoord.z <= run.y + 4.0 * CONTACT_DEPTH_TOLERANCE) discard;
    out_beyond = gl_FragCoord.z;
}
